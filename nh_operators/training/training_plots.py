"""Loss against training time: the curves that show what a budget buys."""

import csv
from pathlib import Path

import numpy as np

from .._figures import new_figure

__all__ = ["read_history", "plot_training_curves", "minutes_to_reach"]


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
    many = len(runs) > 4
    fig = new_figure(figsize=(10, 4.5) if many else (7, 4.5))
    ax = fig.subplots()
    for i, (label, run) in enumerate(runs.items()):
        h = run if isinstance(run, dict) else read_history(run)
        minutes = h["seconds"] / 60.0
        ax.plot(minutes, h["val_loss"], "-", color=f"C{i % 10}", label=label)
        ax.plot(minutes, h["train_loss"], "--", color=f"C{i % 10}", alpha=0.6)
    ax.plot([], [], "k-", label="validation (solid)")
    ax.plot([], [], "k--", alpha=0.6, label="training (dashed)")
    for j, (label, value) in enumerate((goals or {}).items()):
        ax.axhline(value, linestyle=":", color="k", alpha=0.5 + 0.1 * j, label=label)
    ax.set(yscale="log", xlabel="training time (minutes)", ylabel="loss (mean over outputs)")
    ax.grid(True, which="major", alpha=0.3)
    if many:  # beside the axes, where it hides no curve
        ax.legend(fontsize="small", loc="center left", bbox_to_anchor=(1.01, 0.5))
    else:
        ax.legend(fontsize="small")
    if title is not None:
        ax.set_title(title)
    return fig


def minutes_to_reach(history, goal, *, fraction=0.5):
    """Extrapolate when the validation loss would reach ``goal`` at the current pace.

    Fits log(best validation loss so far) = a + b·log(minutes) to the last ``fraction``
    of the epochs and solves for the goal. A rough guide, not a promise: the fit cannot
    know about plateaus, and a schedule that decays its learning rate towards the end
    bends the curve down (then the fit is optimistic for a longer run of the same
    schedule shape, pessimistic for continuing this one).

    Args:
        history: dict of :func:`read_history` (or a run directory).
        goal: the loss to reach.
        fraction: share of the epochs (the last ones) in the fit.

    Returns:
        (minutes, slope b): minutes is the total training time at which the fit reaches
        ``goal`` (already spent if the run is there), ``inf`` when the loss is not
        falling (b ≥ 0).

    Example:
        >>> m = np.linspace(1, 10, 10)
        >>> minutes, b = minutes_to_reach({"seconds": 60 * m, "val_loss": 2 / m}, 1e-3)
        >>> round(minutes), round(b, 6)
        (2000, -1.0)
    """
    h = history if isinstance(history, dict) else read_history(history)
    minutes = np.asarray(h["seconds"], dtype=float) / 60.0
    best = np.minimum.accumulate(np.asarray(h["val_loss"], dtype=float))
    if best[-1] <= goal:
        return float(minutes[np.argmax(best <= goal)]), 0.0
    k = max(2, int(round(fraction * len(best))))
    b, a = np.polyfit(np.log(minutes[-k:]), np.log(best[-k:]), 1)
    if b > -1e-9:  # flat (up to rounding) or rising
        return float("inf"), float(b)
    with np.errstate(over="ignore"):
        return float(np.exp((np.log(goal) - a) / b)), float(b)
