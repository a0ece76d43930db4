"""
Neural Hamilton without labels
==============================

A network can be trained on Hamilton's equations themselves, dq/dt = p and
dp/dt = −V'(q), instead of on solved trajectories: ``TrainConfig(physics=...)`` makes
the residual the loss (``PhysicsTerms``). And a trained network's prediction on a
potential it has never seen can be refined at test time with ``nh.refine``.

This tutorial shows both, small enough for a CPU in seconds. What they buy at real
budgets is measured by ``benchmarks/physics/without_labels.py`` and
``benchmarks/physics/refine.py`` (docs page "Neural Hamilton without labels"): in short,
label-free training has not learned the trajectories at the budgets measured, and
Newton refinement of a network's prediction reaches the exact trajectory of a smooth
potential but costs more than the classical solver does.
"""

# %%
# Training on the residual
# ------------------------
# A physics-informed run is a training mode like any other: checkpoints, resume and the
# validation loss against the labels (the paper's L_tot), which shows whether the
# residual leads anywhere. ``physics={}`` is the residual alone; here also the energy
# term and a curriculum that widens the time horizon from 0.25 to 2 over 200 iterations.
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import torch

import nh_operators as nh
from nh_operators.data import preset_kwargs
from nh_operators.solvers import reference_solve

torch.set_num_threads(1)
folder = Path(tempfile.mkdtemp())
nh.generate_dataset(200, 0, str(folder / "train.h5"), progress=False,
                    **preset_kwargs("paper-standard"))
config = nh.TrainConfig("deeponet", preset="cpu", epochs=20, batch_size=40,
                        scheduler="constant", lr=1e-3, device="cpu", seed=0,
                        physics={"energy": 1.0, "curriculum": 200})
net, history = nh.train(config, str(folder / "train.h5"), folder / "run", progress=False)
print("epoch  residual loss  validation L_tot (labels)")
for h in history[::4] + history[-1:]:
    print(f"{h['epoch']:5d}  {h['train_loss']:13.3e}  {h['val_loss']:.3e}")

# %%
# The residual falls; the validation L_tot (against labels the run never saw) does not:
# at this budget, as at the 90 CPU minutes of the benchmark, the label-free network has
# not found the trajectories.
#
# Refining a prediction at test time
# ----------------------------------
# ``nh.refine(model, V, t, method="newton")`` keeps the network and refines its
# trajectory: the prediction is the first guess of a Chebyshev collocation solve that
# Newton's method drives to ``tol``. Here the shipped DeepONet on the Morse potential,
# against the reference solve.
model = nh.pretrained("deeponet-paper")
morse = nh.PHYSICAL_POTENTIALS["morse"]
q_ref, p_ref = (np.asarray(a).reshape(-1) for a in reference_solve(morse, nh.TIMES))
q_net, p_net = nh.predict(model, morse.V(nh.SENSORS), nh.TIMES)
refined = nh.refine(model, morse, nh.TIMES, method="newton", tol=1e-10)


def l_tot(q, p):
    return 0.5 * (np.mean((q - q_ref) ** 2) + np.mean((p - p_ref) ** 2))


print(f"network L_tot {l_tot(q_net, p_net):.1e}; refined {l_tot(refined.q, refined.p):.1e} "
      f"(converged {refined.converged}, estimate {refined.estimate:.1e}, "
      f"{refined.steps} Newton steps, {refined.seconds * 1e3:.1f} ms)")
classical = nh.solve_classical(morse, nh.TIMES, tol=1e-14)
print(f"classical solver to 1e-14: L_tot {l_tot(classical.q, classical.p):.1e}")

fig, ax = plt.subplots(figsize=(6.4, 3.2))
ax.semilogy(nh.TIMES, np.abs(q_net - q_ref) + 1e-18, label="network")
ax.semilogy(nh.TIMES, np.abs(refined.q - q_ref) + 1e-18, label="refined (Newton)")
ax.set_xlabel("t")
ax.set_ylabel("|q − q_ref|")
ax.set_title("Morse: the shipped DeepONet and its refinement")
ax.legend()
fig.tight_layout()

# %%
# Without the network's guess, the same Newton iteration from q ≡ 0 does not converge
# on this potential (it diverges); with it, the collocation reaches rounding. The
# classical solver still gets there faster (``benchmarks/physics/refine.py`` gives the
# table), so refinement pays only where no fast solver exists.
