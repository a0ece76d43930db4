"""Trained weights shipped inside the package, loaded offline: ``nh.pretrained("deeponet")``.

Each model lives in ``nh_operators/solving/weights/NAME/``:

* ``checkpoint.pt`` — the network's weights, its config and the training dataset's
  checksum (a run's checkpoint without the optimiser, scheduler and RNG states, so
  :func:`~nh_operators.load_model` reads it, but ``train --resume`` does not);
* ``config.json`` and ``history.csv`` — as in the run directory it came from;
* ``metrics.json`` — its ``report.json`` entry (test set, physical potentials, timings,
  device) and the commands that regenerate weights and metrics.

:func:`export_pretrained` writes such a folder from a run directory
(``nh-operators export``).
"""

import io
import json
import shutil
from pathlib import Path

import numpy as np
import torch

from ..training import CHECKPOINT, CONFIG, HISTORY, load_checkpoint, write_atomic
from .catalog import DOMAIN, WEIGHTS, network_domain, refresh, resolve_pretrained

__all__ = ["export_pretrained", "pretrained", "refit_domain"]

METRICS = "metrics.json"
_SLIM = ("format", "config", "model", "epoch", "data_checksum", "version")


def pretrained(name, *, device="cpu", batch_size=1000):
    """A shipped model as a :class:`~nh_operators.NeuralMethod`, loaded offline.

    Args:
        name: one of :func:`available_pretrained`.
        device: ``"cpu"`` or a CUDA device.
        batch_size: potentials per forward pass.

    Returns:
        NeuralMethod with ``config`` (training config), ``metrics`` (its evaluation
        and the commands that reproduce it) and ``shipped`` (the name). Call it as
        ``method(V, t)``, or pass it to :func:`~nh_operators.predict` or as
        :func:`~nh_operators.solve`'s ``method``; the network is ``method.net``.

    Raises:
        ValueError: for an unknown name (listing the available ones).

    Example:
        >>> import nh_operators as nh
        >>> model = pretrained("deeponet")
        >>> q, p = model(nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS)[None], nh.TIMES)
        >>> q.shape
        (1, 100)
    """
    from ..evaluation import NeuralMethod

    name = resolve_pretrained(name)  # "TraONet" is "traonet-alg1"
    folder = WEIGHTS / name
    method = NeuralMethod.from_run(folder, device=device, name=name, batch_size=batch_size)
    method.domain = network_domain(name)
    metrics = folder / METRICS
    method.metrics = json.loads(metrics.read_text()) if metrics.is_file() else {}
    method.shipped = name  # solve(..., method=this) uses the shipped calibration of name
    return method


def export_pretrained(run_dir, out_dir, *, report=None, name=None, commands=(), data=None):
    """Write a shippable model folder from a run directory.

    Args:
        run_dir: a run written by ``nh-operators train``.
        out_dir: destination folder (e.g. ``nh_operators/solving/weights/NAME``); created or
            overwritten file by file, atomically.
        report: optional ``report.json`` of ``nh-operators evaluate`` that includes
            the run; its entry for the model becomes ``metrics.json``.
        name: the model's key in the report (default: the run's model name).
        commands: the command lines that regenerate the weights and the metrics.
        data: the run's training dataset (.h5). Its training rows, split as the run split
            them, give ``domain.json`` (:func:`~nh_operators.potentials.fit_domain`):
            ``solve`` then uses the network only on inputs like them.

    Returns:
        Path of the folder.

    Raises:
        FileNotFoundError: if the run has no checkpoint.
        ValueError: if the report has no entry for the model, or ``data`` is not the
            dataset the run trained on (checksum).
    """
    state = load_checkpoint(run_dir)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    buf = io.BytesIO()
    torch.save({k: state[k] for k in _SLIM if k in state}, buf)
    write_atomic(out / CHECKPOINT, buf.getvalue())
    for fname in (CONFIG, HISTORY):
        src = Path(run_dir) / fname
        if src.is_file():
            shutil.copyfile(src, out / (fname + ".tmp"))
            (out / (fname + ".tmp")).replace(out / fname)
    metrics = {"model": state["config"]["model"], "epochs": state["epoch"],
               "data_checksum": state.get("data_checksum"), "commands": list(commands)}
    if report is not None:
        entry = json.loads(Path(report).read_text())["methods"].get(name or metrics["model"])
        if entry is None:
            raise ValueError(f"{report} has no entry for {name or metrics['model']!r}")
        entry = {k: v for k, v in entry.items() if k not in ("run_dir", "config")}
        metrics["evaluation"] = entry
    write_atomic(out / METRICS, (json.dumps(metrics, indent=2) + "\n").encode())
    if data is not None:
        domain = training_domain(data, state)
        write_atomic(out / DOMAIN, (json.dumps(domain, indent=2) + "\n").encode())
    refresh()  # weights exported into the package are available from now on
    return out


def refit_domain(name, data):
    """Fit ``domain.json`` of shipped model ``name`` again from the dataset it trained on
    (its training rows as the run split them), as :func:`export_pretrained` does: for a
    domain fitted before a bound was added.

    ``data`` must be that dataset (checksum), or one with the same sensor values and
    other labels (a dataset generated again after the labels' solver changed): then
    every bound already in ``domain.json`` must come out the same (to 1e-12, relative).

    Returns:
        the domain written.

    Raises:
        ValueError: if ``data`` is neither.
    """
    name = resolve_pretrained(name)
    state = load_checkpoint(WEIGHTS / name)
    try:
        domain = training_domain(data, state)
    except ValueError:
        domain = training_domain(data, {**state, "data_checksum": None})
        old = json.loads((WEIGHTS / name / DOMAIN).read_text())
        changed = [k for k in old if k != "source" and not np.allclose(
            old[k], domain.get(k, np.nan), rtol=1e-12, atol=0.0)]
        if changed:
            raise ValueError(f"{data} is not the dataset {name} trained on: its training "
                             f"rows give other {', '.join(changed)}") from None
    write_atomic(WEIGHTS / name / DOMAIN, (json.dumps(domain, indent=2) + "\n").encode())
    refresh()
    return domain


def training_domain(data, state):
    """:func:`~nh_operators.potentials.fit_domain` of the rows a run trained on.

    Args:
        data: path of the run's dataset.
        state: the run's checkpoint dict (its config and ``data_checksum``).

    Raises:
        ValueError: if ``data`` is not the dataset of the checkpoint.
    """
    from ..data import load_dataset
    from ..potentials import fit_domain

    from ..data.generate import checksum_mismatch

    dataset = load_dataset(data)
    if state.get("data_checksum") not in (None, dataset.checksum):
        raise ValueError(f"{data}: " + checksum_mismatch(
            "the dataset this run trained on", state["data_checksum"], dataset,
            state.get("data_draw")))
    train, _ = dataset.split_indices(state["config"].get("train_fraction", 0.8))
    domain = fit_domain(dataset.V[np.sort(train)],
                        source=f"{Path(data).stem} (training rows)")
    domain["V_range"] = list(domain["V_range"])
    return domain
