"""The phase portrait of a whole orbit, with the asked times marked (``predict --out``)."""

import numpy as np

from .._figures import new_figure

__all__ = ["plot_orbit"]


def plot_orbit(q_orbit, p_orbit, t, q, p, *, title=None):
    """One closed orbit in the (q, p) plane, and the states at the asked times on it.

    Args:
        q_orbit, p_orbit: (K,) the orbit over one period (or the solved span).
        t, q, p: (M,) the asked times and the states there (marked, coloured by t).
        title: figure title.

    Returns:
        matplotlib.figure.Figure.

    Example:
        >>> s = np.linspace(0, 2 * np.pi, 50)
        >>> fig = plot_orbit(0.5 + 0.3 * np.cos(s), -1.2 * np.sin(s), [1.0], [0.8], [0.0])
        >>> len(fig.axes)
        2
    """
    fig = new_figure(figsize=(5.5, 4.5))
    ax = fig.add_subplot()
    ax.plot(q_orbit, p_orbit, color="k", linewidth=1.0, label="orbit")
    marks = ax.scatter(q, p, c=np.asarray(t, dtype=np.float64), cmap="viridis", s=28,
                       zorder=3, label="asked times")
    fig.colorbar(marks, ax=ax, label="t")
    ax.set(xlabel="q", ylabel="p", title=title or "phase portrait", xlim=(-0.02, 1.02))
    ax.legend(fontsize="small")
    return fig
