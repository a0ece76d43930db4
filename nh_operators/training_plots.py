"""Loss against training time: the curves that show what a budget buys."""

import csv
from pathlib import Path

import numpy as np

from .plots import _figure

__all__ = ["read_history", "plot_training_curves"]


def read_history(run_dir):
    """A run's ``history.csv`` as arrays.

    Args:
        run_dir: a run directory (or the csv file itself).

    Returns:
        dict of float arrays ``epoch``, ``train_loss``, ``val_loss``, ``lr``, ``seconds``.

    Raises:
        FileNotFoundError: if there is no history; ValueError if it is empty.
    """
    path = Path(run_dir)
    path = path / "history.csv" if path.is_dir() else path
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path} holds no epochs")
    return {key: np.array([float(r[key]) for r in rows]) for key in rows[0]}


def plot_training_curves(runs, *, title=None, goals=None):
    """Validation (solid) and training (dashed) loss against wall-clock minutes.

    Args:
        runs: dict label -> run directory (or history dict of :func:`read_history`).
        title: optional title.
        goals: optional dict label -> a loss to reach, drawn as a dotted line.

    Returns:
        matplotlib.figure.Figure with one log-scale axes.

    Raises:
        ValueError: if ``runs`` is empty.
    """
    if not runs:
        raise ValueError("no runs to plot")
    fig = _figure(figsize=(7, 4.5))
    ax = fig.subplots()
    for i, (label, run) in enumerate(runs.items()):
        h = run if isinstance(run, dict) else read_history(run)
        minutes = h["seconds"] / 60.0
        ax.plot(minutes, h["val_loss"], "-", color=f"C{i % 10}", label=f"{label} (validation)")
        ax.plot(minutes, h["train_loss"], "--", color=f"C{i % 10}", alpha=0.6,
                label=f"{label} (training)")
    for j, (label, value) in enumerate((goals or {}).items()):
        ax.axhline(value, linestyle=":", color="k", alpha=0.5 + 0.1 * j, label=label)
    ax.set(yscale="log", xlabel="training time (minutes)", ylabel="loss (mean over outputs)")
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize="small")
    if title is not None:
        ax.set_title(title)
    return fig
