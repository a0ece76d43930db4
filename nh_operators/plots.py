"""Functions that return matplotlib figures (never show them)."""

import numpy as np

from ._constants import TIMES

__all__ = ["plot_physical_potentials"]


def plot_physical_potentials(potentials, trajectories, t=TIMES):
    """Potential, q(t), p(t) and phase portrait of each potential, one column each.

    Args:
        potentials: dict name -> object with ``V(q)``.
        trajectories: dict name -> (q, p) at times t.
        t: times of the trajectories.

    Returns:
        matplotlib.figure.Figure
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    names = list(trajectories)
    fig = Figure(figsize=(3.2 * len(names), 10), layout="constrained")
    axes = fig.subplots(4, len(names), squeeze=False)
    grid = np.linspace(0.0, 1.0, 400)
    for col, name in enumerate(names):
        q, p = trajectories[name]
        axes[0, col].plot(grid, potentials[name].V(grid))
        axes[0, col].set(title=name, xlabel="q", ylabel="V(q)")
        axes[1, col].plot(t, q)
        axes[1, col].set(xlabel="t", ylabel="q(t)")
        axes[2, col].plot(t, p)
        axes[2, col].set(xlabel="t", ylabel="p(t)")
        axes[3, col].scatter(q, p, c=t, s=6, cmap="viridis")
        axes[3, col].set(xlabel="q", ylabel="p", title="phase portrait (colour: t)")
    return fig
