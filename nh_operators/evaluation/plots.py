"""Functions that return matplotlib figures (never show them).

Every function builds a :class:`matplotlib.figure.Figure` directly (no pyplot, no global
figure state) on the Agg backend, so they run headless; save with ``fig.savefig(path)``.
Time is always shown with one colour map (:data:`CMAP`) and one colorbar labelled ``t``.
"""

import numpy as np

from ._constants import SENSORS, TIMES, V0

__all__ = ["CMAP", "log_bins", "plot_trajectory", "plot_worst_sample", "plot_loss_histograms",
           "plot_work_precision", "plot_physical_potentials"]

#: Colour map for time in every figure.
CMAP = "viridis"

_NEURAL_MARKERS = ("*", "D", "s", "P", "X", "^", "v", "p", "h", "o")
_X_AXES = {"seconds_per_trajectory": ("seconds per trajectory", lambda s: s),
           "trajectories_per_second": ("trajectories per second", lambda s: 1.0 / s)}


def _figure(**kwargs):
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    return Figure(layout="constrained", **kwargs)


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
    segments = LineCollection(np.stack([xy[:-1], xy[1:]], axis=1), cmap=CMAP, norm=norm,
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
    fig = _figure(figsize=(10, 7))
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


def log_bins(values_list, bins):
    """Log-spaced histogram edges covering every value of every array.

    Args:
        values_list: iterable of array-likes of positive finite values, any shapes.
        bins: number of bins (≥ 1); 30 to 50 suit a few thousand samples.

    Returns:
        float64 array of shape (bins + 1,), geometrically spaced, with ``edges[0]``
        the smallest value and ``edges[-1]`` the largest (a single repeated value
        gets the decade around it).

    Raises:
        ValueError: if there are no values, a value is not positive and finite, or
            ``bins`` < 1.

    Example:
        >>> log_bins([np.array([1e-6, 1e-3]), [1e-4]], 3)
        array([1.e-06, 1.e-05, 1.e-04, 1.e-03])
    """
    if int(bins) != bins or bins < 1:
        raise ValueError(f"bins must be a positive integer, got {bins!r}")
    v = np.concatenate([np.asarray(a, dtype=np.float64).ravel() for a in values_list] + [[]])
    if v.size == 0:
        raise ValueError("log_bins needs at least one value")
    bad = np.count_nonzero(~(np.isfinite(v) & (v > 0)))
    if bad:
        raise ValueError(f"{bad} of {v.size} values are not positive and finite")
    lo, hi = float(v.min()), float(v.max())
    if lo == hi:
        lo, hi = lo / np.sqrt(10.0), hi * np.sqrt(10.0)
    edges = np.logspace(np.log10(lo), np.log10(hi), int(bins) + 1)
    edges[0], edges[-1] = lo, hi  # exact ends, whatever log10 rounds to
    return edges


def plot_loss_histograms(losses, *, bins=40, title=None):
    """Histograms of per-sample L_tot of several methods on shared log-spaced bins.

    One step histogram per method on a single log-x axes, each with its median as a
    dashed vertical line of the same colour; the legend gives each median.

    Args:
        losses: dict name -> per-sample L_tot, array of shape (N_name,) (the sizes
            may differ). Up to 10 methods stay legible (20 distinct colours).
        bins: number of log-spaced bins shared by all methods (see :func:`log_bins`).
        title: optional axes title.

    Returns:
        matplotlib.figure.Figure with one axes, legend to its right; ``ax.patches[i]``
        is method i's histogram (a ``StepPatch``) and ``ax.lines[i]`` its median.

    Raises:
        ValueError: if ``losses`` is empty, or a method has no values or values
            that are not positive and finite (the message names it and the count).

    Example:
        >>> rng = np.random.default_rng(0)
        >>> fig = plot_loss_histograms({"a": 10 ** rng.normal(-5, 1, 200),
        ...                             "b": 10 ** rng.normal(-7, 1, 300)}, bins=20)
        >>> ax = fig.axes[0]
        >>> ax.get_xscale(), [int(h.get_data().values.sum()) for h in ax.patches]
        ('log', [200, 300])
    """
    if not losses:
        raise ValueError("losses is empty: give at least one method")
    arrays = {}
    for name, values in losses.items():
        v = np.asarray(values, dtype=np.float64).ravel()
        if v.size == 0:
            raise ValueError(f"losses[{name!r}] is empty")
        bad = np.count_nonzero(~(np.isfinite(v) & (v > 0)))
        if bad:
            raise ValueError(f"losses[{name!r}]: {bad} of {v.size} values are not positive "
                             "and finite")
        arrays[name] = v
    edges = log_bins(arrays.values(), bins)
    import matplotlib

    colours = matplotlib.colormaps["tab10" if len(arrays) <= 10 else "tab20"].colors
    fig = _figure(figsize=(10, 4.8))
    ax = fig.subplots()
    for i, (name, v) in enumerate(arrays.items()):
        colour = colours[i % len(colours)]
        counts, _ = np.histogram(v, edges)
        median = float(np.median(v))
        ax.stairs(counts, edges, color=colour, linewidth=1.4,
                  label=f"{name} (median {median:.2e}, n = {v.size})")
        ax.axvline(median, color=colour, linestyle="--", linewidth=1.0)
    ax.set(xscale="log", xlabel="per-sample L_tot", ylabel="samples")
    fig.legend(loc="outside right upper", fontsize="small")
    if title is not None:
        ax.set_title(title)
    return fig


def _check_rows(rows):
    if len(rows) == 0:
        raise ValueError("rows is empty: give at least one method")
    for i, row in enumerate(rows):
        missing = [k for k in ("name", "kind", "family", "seconds", "mean_L_tot") if k not in row]
        if missing:
            raise ValueError(f"rows[{i}] lacks {', '.join(missing)}")
        if row["kind"] not in ("neural", "classical"):
            raise ValueError(f"rows[{i}] ({row['name']}): kind must be 'neural' or "
                             f"'classical', got {row['kind']!r}")
        for key in ("seconds", "mean_L_tot"):
            value = float(row[key])
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"rows[{i}] ({row['name']}): {key} = {value!r} must be "
                                 "positive and finite (log axes)")


def plot_work_precision(rows, *, title=None, x="seconds_per_trajectory"):
    """Work-precision diagram: cost per trajectory against test-set mean L_tot.

    Classical methods of one family (e.g. an RK4 at 1, 4, 16 steps) form one line,
    their points joined in order of cost; each neural model is one large marker.
    A classical point is annotated with what its name adds to its family's (``4`` for
    ``rk4_sensors_4``), a network with its name. Both axes are logarithmic.

    Args:
        rows: list of dicts with keys ``name`` (str), ``kind`` (``"neural"`` or
            ``"classical"``), ``family`` (str; used for classical rows), ``seconds``
            (float, time per trajectory) and ``mean_L_tot`` (float).
        title: optional axes title.
        x: the x axis: ``"seconds_per_trajectory"`` (``seconds``) or
            ``"trajectories_per_second"`` (its inverse).

    Returns:
        matplotlib.figure.Figure with one log-log axes; ``ax.lines`` holds one line
        per classical family (in order of first appearance), ``ax.collections`` one
        marker per neural model.

    Raises:
        ValueError: if ``rows`` is empty, a row lacks a key or has an unknown kind,
            a time or loss is not positive and finite, or ``x`` is unknown.

    Example:
        >>> fig = plot_work_precision([
        ...     {"name": "rk4 x1", "kind": "classical", "family": "rk4", "seconds": 8e-6,
        ...      "mean_L_tot": 3e-6},
        ...     {"name": "rk4 x4", "kind": "classical", "family": "rk4", "seconds": 2e-5,
        ...      "mean_L_tot": 6e-11},
        ...     {"name": "traonet", "kind": "neural", "family": "traonet",
        ...      "seconds": 2e-3, "mean_L_tot": 1e-5}])
        >>> ax = fig.axes[0]
        >>> ax.get_xscale(), ax.get_yscale(), len(ax.lines), len(ax.collections)
        ('log', 'log', 1, 1)
    """
    if x not in _X_AXES:
        raise ValueError(f"x must be one of {sorted(_X_AXES)}, got {x!r}")
    _check_rows(rows)
    xlabel, transform = _X_AXES[x]
    fig = _figure(figsize=(8, 5.5))
    ax = fig.subplots()
    logs = np.log10(transform(np.array([float(r["seconds"]) for r in rows])))
    middle = 0.5 * (logs.min() + logs.max())

    def note(text, xi, yi, **kwargs):  # right of a point, or left of one on the right
        right = np.log10(xi) <= middle
        ax.annotate(text, (xi, yi), textcoords="offset points", xytext=(5 if right else -7, 4),
                    ha="left" if right else "right", fontsize=7, **kwargs)

    families = {}
    for row in rows:
        if row["kind"] == "classical":
            families.setdefault(row["family"], []).append(row)
    for i, (family, members) in enumerate(families.items()):
        members = sorted(members, key=lambda r: float(r["seconds"]))
        xs = transform(np.array([float(r["seconds"]) for r in members]))
        ys = np.array([float(r["mean_L_tot"]) for r in members])
        ax.plot(xs, ys, "o-", color=f"C{i % 10}", markersize=4, linewidth=1.2, label=family)
        for r, xi, yi in zip(members, xs, ys):  # the knob only: "4" for rk4_sensors_4
            name = str(r["name"])
            note(name[len(family) + 1:] if name.startswith(family + "_") else name, xi, yi,
                 color=f"C{i % 10}")
    neural = [r for r in rows if r["kind"] == "neural"]
    for i, row in enumerate(neural):
        xi, yi = transform(float(row["seconds"])), float(row["mean_L_tot"])
        ax.scatter([xi], [yi], s=130, marker=_NEURAL_MARKERS[i % len(_NEURAL_MARKERS)],
                   color=f"C{(len(families) + i) % 10}", edgecolors="k", linewidths=0.6,
                   zorder=3, label=str(row["name"]))
        note(str(row["name"]), xi, yi, fontweight="bold")
    ax.set(xscale="log", yscale="log", xlabel=xlabel, ylabel="test-set mean L_tot")
    ax.grid(True, which="major", alpha=0.3)
    ax.margins(0.08)  # room for the annotations
    ax.legend(fontsize="small", ncols=1 if len(families) + len(neural) <= 8 else 2)
    if title is not None:
        ax.set_title(title)
    return fig


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
    fig = _figure(figsize=(3.2 * len(names) + 1, 10))
    axes = fig.subplots(4, len(names), squeeze=False)
    norm = _time_norm(t)
    for col, name in enumerate(names):
        q, p = trajectories[name]
        q, p = _vector(f"{name}: q", q, t.size), _vector(f"{name}: p", p, t.size)
        _draw_trajectory(axes[:, col], potentials[name], t, q, p, None, None, norm, None)
        axes[0, col].set_title(name)
    _colorbar(fig, axes, norm)
    return fig
