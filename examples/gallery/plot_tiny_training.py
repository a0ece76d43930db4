"""
Train two networks for a few epochs and compare them with the solvers
=====================================================================

The whole training path at toy scale: generate 200 labelled potentials, train DeepONet
and TraONet (``cpu`` presets) for a few epochs in DeepXDE's loop, and score them next
to two classical baselines on 100 test potentials.

Real runs are the same calls with the standard dataset (10,000 potentials,
``nh-operators generate --preset standard``) and the paper's 250 epochs; a few epochs
on 160 training samples show the machinery, not the accuracy.
"""

# %%
# Data
# ----
# A training set (80 % train, 20 % validation, split by the dataset's seed) and a
# separate test set. Both are written as HDF5 files, as ``nh-operators generate``
# would write them; the run directories go next to them.
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

import nh_operators as nh
from nh_operators.data import generate_dataset

work = Path(tempfile.mkdtemp(prefix="nh_tiny_"))
train_set = generate_dataset(200, seed=8407, path=work / "train.h5", progress=False)
test_set = generate_dataset(100, seed=42, path=work / "test.h5", progress=False)
print(len(train_set), "training potentials,", len(test_set), "test potentials")

# %%
# Training
# --------
# :class:`nh_operators.TrainConfig` holds everything that defines a run; unset
# learning-rate values take the paper's tuned ones for the model. ``train`` writes
# ``checkpoint.pt`` (every epoch), ``config.json`` and ``history.csv`` in the run
# directory; ``resume=True`` would continue a killed run.
runs, histories = {}, {}
for name, epochs in (("deeponet", 10), ("traonet", 3)):
    config = nh.TrainConfig(name, preset="cpu", epochs=epochs, seed=0, device="cpu")
    net, history = nh.train(config, train_set, work / name, progress=False)
    runs[name], histories[name] = work / name, history
    last = history[-1]
    print(f"{name}: {nh.count_parameters(net):,} parameters, {epochs} epochs in "
          f"{last['seconds']:.1f} s, validation loss {last['val_loss']:.3e}")

fig, ax = plt.subplots(figsize=(6.4, 4), layout="constrained")
for name, history in histories.items():
    epochs = [r["epoch"] for r in history]
    (line,) = ax.semilogy(epochs, [r["train_loss"] for r in history], label=f"{name} train")
    ax.semilogy(epochs, [r["val_loss"] for r in history], "--", color=line.get_color(),
                label=f"{name} validation")
ax.set(xlabel="epoch", ylabel="mean squared error of (q, p)")
ax.legend()

# %%
# Evaluation
# ----------
# :func:`nh_operators.evaluate_methods` scores every method on the same inputs (the
# 100 sensor values) with the paper's per-sample loss, on the five physical
# potentials, and times it. The settings here time only a few calls.
from nh_operators.evaluation import (
    plot_loss_histograms,
    plot_work_precision,
    work_precision_rows,
)

methods = {name: nh.NeuralMethod.from_run(run) for name, run in runs.items()}
methods.update({name: nh.CLASSICAL_METHODS[name]
                for name in ("rk4_sensors_1", "rk4_sensors_4")})
settings = nh.EvaluationSettings(n_single=5, n_batched=100, repeats=3)
results, arrays = nh.evaluate_methods(methods, test_set, settings, progress=False)

for name, entry in results["methods"].items():
    test, times = entry["test"], entry["seconds_per_trajectory"]
    print(f"{name:14s} mean L_tot {test['mean']:.2e}  median {test['median']:.2e}  "
          f"{times['batched'] * 1e6:8.1f} µs/trajectory (batch {times['batched_size']})")

histograms = plot_loss_histograms({name: a["L_tot"] for name, a in arrays.items()},
                                  title="per-sample L_tot on 100 test potentials")
work_precision = plot_work_precision(work_precision_rows(results),
                                     title="cost against accuracy (batch of 100)")

# %%
# The datasets and runs were written to a temporary folder; remove it.
shutil.rmtree(work)
