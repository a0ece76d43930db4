"""Figures of a whole evaluation: loss histograms and the work-precision diagram.

Like :mod:`.plots`, every function returns a :class:`matplotlib.figure.Figure` built on
the Agg backend and never shows it.
"""

from typing import Any

import numpy as np

from .._figures import new_figure

__all__ = ["log_bins", "plot_loss_histograms", "plot_work_precision"]

_NEURAL_MARKERS = ("*", "D", "s", "P", "X", "^", "v", "p", "h", "o")
_X_AXES = {"seconds_per_trajectory": ("seconds per trajectory", lambda s: s),
           "trajectories_per_second": ("trajectories per second", lambda s: 1.0 / s)}


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

    # a ListedColormap: .colors is its list of RGB tuples (typed as any colour data)
    palette: Any = matplotlib.colormaps["tab10" if len(arrays) <= 10 else "tab20"]
    colours = palette.colors
    fig = new_figure(figsize=(10, 4.8))
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
    fig = new_figure(figsize=(8, 5.5))
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
        for r, xi, yi in zip(members, xs, ys, strict=True):  # the knob only: "4" for rk4_sensors_4
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
