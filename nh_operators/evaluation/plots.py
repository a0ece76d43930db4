"""Figures of trajectories: one potential, a worst sample, the physical potentials.

The figures of a whole set (histograms, work precision) are in :mod:`.summary_plots`.

Every function builds a :class:`matplotlib.figure.Figure` directly (no pyplot, no global
figure state) on the Agg backend, so they run headless; save with ``fig.savefig(path)``.
Time is always shown with one colour map (:data:`CMAP`) and one colorbar labelled ``t``.
"""

import numpy as np

from .._constants import SENSORS, TIMES, V0
from .._figures import new_figure

__all__ = ["CMAP", "plot_trajectory", "plot_worst_sample", "plot_physical_potentials"]

#: Colour map for time in every figure.
CMAP = "viridis"



def _vector(name, x, n=None):
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {a.shape}")
    if n is not None and a.size != n:
        raise ValueError(f"{name} has {a.size} values but t has {n}")
    return a


def _time_norm(t):
    from matplotlib.colors import Normalize

    return Normalize(vmin=float(np.min(t)), vmax=float(np.max(t)))


def _draw_potential(ax, potential):
    """V on [0, 1]: a curve from ``potential.V``, or the 100 sensor values as points."""
    if hasattr(potential, "V"):
        grid = np.linspace(0.0, 1.0, 400)
        values = np.asarray(potential.V(grid), dtype=np.float64)
        if values.size != grid.size:
            raise ValueError(f"potential.V of 400 points returned shape {values.shape}; "
                             "pass a single potential, not a batch")
        ax.plot(grid, values.reshape(grid.shape), color="k", label="V")
    else:
        values = np.asarray(potential, dtype=np.float64)
        if values.shape != SENSORS.shape:
            raise ValueError(f"sensor values must have shape {SENSORS.shape}, got {values.shape}")
        ax.plot(SENSORS, values, "o-", color="k", markersize=2.5, linewidth=0.8,
                label="V at sensors")
    ax.axhline(V0, color="0.6", linestyle="--", linewidth=0.8, label="E = V0")
    ax.set(xlabel="q", ylabel="V(q)", xlim=(0.0, 1.0))


def _draw_trajectory(axes, potential, t, q, p, q_pred, p_pred, norm, label):
    """Fill four axes: V, q(t), p(t), phase portrait; truth as lines, prediction as points."""
    from matplotlib.collections import LineCollection

    ax_v, ax_q, ax_p, ax_ph = axes
    _draw_potential(ax_v, potential)
    point = dict(c=t, cmap=CMAP, norm=norm, s=10, zorder=3, label=label)
    for ax, truth, pred, name in ((ax_q, q, q_pred, "q"), (ax_p, p, p_pred, "p")):
        ax.plot(t, truth, color="k", linewidth=1.2, label="truth")
        if pred is not None:
            ax.scatter(t, pred, **point)
        ax.set(xlabel="t", ylabel=f"{name}(t)")
    xy = np.column_stack([q, p])
    segments = LineCollection(list(np.stack([xy[:-1], xy[1:]], axis=1)), cmap=CMAP, norm=norm,
                              linewidth=1.5, label="truth")
    segments.set_array(0.5 * (t[:-1] + t[1:]))
    ax_ph.add_collection(segments)
    ax_ph.autoscale_view()
    if q_pred is not None and p_pred is not None:
        ax_ph.scatter(q_pred, p_pred, marker="x", **point)
    ax_ph.set(xlabel="q", ylabel="p", title="phase portrait")
    if q_pred is not None or p_pred is not None:
        (ax_q if q_pred is not None else ax_p).legend(fontsize="small")


def _colorbar(fig, axes, norm):
    from matplotlib.cm import ScalarMappable

    return fig.colorbar(ScalarMappable(norm=norm, cmap=CMAP), ax=list(np.ravel(axes)),
                        label="t")


def plot_trajectory(potential, t, q, p, q_pred=None, p_pred=None, *, title=None,
                    label="prediction"):
    """One sample: its potential, q(t), p(t) and phase portrait, against a prediction.

    The truth is drawn as black lines (the phase portrait as a line coloured by time);
    the prediction, if given, as points coloured by time, with one colorbar ``t``.

    Args:
        potential: the potential, either an object with a vectorised ``V(q)`` (drawn as
            a curve on [0, 1]) or its values at :data:`~nh_operators.SENSORS`, shape
            (100,) (drawn as points joined by a line).
        t: times, shape (M,).
        q, p: true trajectory at t, shape (M,) each.
        q_pred, p_pred: optional predicted trajectory, shape (M,) each. The phase
            portrait shows the prediction only when both are given.
        title: optional figure title.
        label: legend label of the prediction.

    Returns:
        matplotlib.figure.Figure with five axes: V, q(t), p(t) and phase portrait
        (``fig.axes[:4]``, in that order) and the colorbar (``fig.axes[4]``).

    Raises:
        ValueError: if t, q, p (or a prediction) are not 1-D of the same length, or
            the potential is neither a single potential nor 100 sensor values.

    Example:
        >>> import nh_operators as nh
        >>> q, p = nh.PHYSICAL_POTENTIALS["sho"].exact(nh.TIMES)
        >>> fig = plot_trajectory(nh.PHYSICAL_POTENTIALS["sho"], nh.TIMES, q, p,
        ...                       q_pred=q + 0.01, p_pred=p - 0.01, title="SHO")
        >>> [ax.get_ylabel() for ax in fig.axes]
        ['V(q)', 'q(t)', 'p(t)', 'p', 't']
    """
    t = _vector("t", t)
    q, p = _vector("q", q, t.size), _vector("p", p, t.size)
    q_pred = None if q_pred is None else _vector("q_pred", q_pred, t.size)
    p_pred = None if p_pred is None else _vector("p_pred", p_pred, t.size)
    if t.size < 2:
        raise ValueError(f"need at least 2 times, got {t.size}")
    fig = new_figure(figsize=(10, 7))
    axes = fig.subplots(2, 2)
    norm = _time_norm(t)
    _draw_trajectory(axes.ravel(), potential, t, q, p, q_pred, p_pred, norm, label)
    _colorbar(fig, axes, norm)
    if title is not None:
        fig.suptitle(title)
    return fig


def plot_worst_sample(name, potential, t, q, p, q_pred, p_pred, loss):
    """The worst test sample of a model, titled with the model's name and its L_tot.

    Args:
        name: the model's name, e.g. ``"traonet"``.
        potential, t, q, p, q_pred, p_pred: as in :func:`plot_trajectory`, shapes
            (100,) or an object with ``V``, and (M,).
        loss: the sample's L_tot (float).

    Returns:
        matplotlib.figure.Figure, as :func:`plot_trajectory`.

    Raises:
        ValueError: as :func:`plot_trajectory`.

    Example:
        >>> t = np.linspace(0.0, 2.0, 5)
        >>> fig = plot_worst_sample("m", 8 * (SENSORS - 0.5) ** 2, t, t, t, t, t, 1e-3)
        >>> fig.get_suptitle()
        'm: worst sample, L_tot = 1.000e-03'
    """
    return plot_trajectory(potential, t, q, p, q_pred, p_pred,
                           title=f"{name}: worst sample, L_tot = {loss:.3e}", label=name)


def plot_physical_potentials(potentials, trajectories, t=TIMES):
    """Potential, q(t), p(t) and phase portrait of each potential, one column each.

    Args:
        potentials: dict name -> object with ``V(q)`` (or 100 sensor values).
        trajectories: dict name -> (q, p), arrays of shape (M,) at times t; one
            column per entry, in order.
        t: times of the trajectories, shape (M,).

    Returns:
        matplotlib.figure.Figure with 4 rows of axes (V, q, p, phase portrait) by
        ``len(trajectories)`` columns, then one colorbar for t.

    Raises:
        ValueError: if a trajectory does not match t, or a potential is missing.

    Example:
        >>> import nh_operators as nh
        >>> sho = nh.PHYSICAL_POTENTIALS["sho"]
        >>> fig = plot_physical_potentials({"sho": sho}, {"sho": sho.exact(nh.TIMES)})
        >>> len(fig.axes)
        5
    """
    t = _vector("t", t)
    names = list(trajectories)
    missing = [n for n in names if n not in potentials]
    if missing:
        raise ValueError(f"no potential for {', '.join(missing)}")
    fig = new_figure(figsize=(3.2 * len(names) + 1, 10))
    axes = fig.subplots(4, len(names), squeeze=False)
    norm = _time_norm(t)
    for col, name in enumerate(names):
        q, p = trajectories[name]
        q, p = _vector(f"{name}: q", q, t.size), _vector(f"{name}: p", p, t.size)
        _draw_trajectory(axes[:, col], potentials[name], t, q, p, None, None, norm, None)
        axes[0, col].set_title(name)
    _colorbar(fig, axes, norm)
    return fig
