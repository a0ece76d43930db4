"""The generator's domain: what its potentials look like at the sensors.

A network trained on the generator's potentials has never seen sensor values outside
these bounds; its outputs there are extrapolation. :func:`domain_violations` says why an
input lies outside, and :class:`OutOfDomainWarning` carries the reasons.
"""

import numba
import numpy as np

from .._constants import SENSORS, V0
from .._sensors import sensor_values
from ._spline_kernels import JIT

__all__ = ["GENERATOR_DOMAIN", "OutOfDomainWarning", "domain_violations", "in_domain",
           "domain_stats", "fit_domain", "wall_forces"]


class OutOfDomainWarning(UserWarning):
    """Sensor values outside the distribution a network was trained on."""


#: What the paper's generator (BoundedPotentialSpace, ω = 0.05, margin 0.05) can produce,
#: as seen at the 100 sensors. ``V_range``: control values lie in [-V0, V0] and the
#: B-spline stays in their convex hull. ``max_slope`` = 4/ω = 80: dV/dq is a weighted
#: mean of the control-polygon slopes ΔV/Δq, with ``|ΔV|`` ≤ 4 and Δq ≥ ω, and a slope between
#: two sensors is a value of dV/dq. ``min_V_at_most``: one control value is -V0 and its
#: basis function peaks at 4/9 or more (4 controls; 0.5 or more otherwise), so min V ≤
#: 2 - 4·4/9 = 2/9 on the curve, and the nearest sensor is within 1/198 in q, so within
#: 80/198 in V: 0.626 (measured on standard.h5 + test.h5, 14,000 potentials: 0.177).
#: ``max_curvature``: second differences of the sensors, empirical: 2,126 at most on
#: those 14,000 (99.9th percentile 1,999), times 1.5. ``min_wall_force``: the force at
#: each wall, -V'(0) and V'(1) from the cubic through the four sensors there, must point
#: inward and exceed it (:func:`wall_forces`). The curve leaves each wall along its
#: first control segment, which may be nearly flat, so only 0 is guaranteed; empirical:
#: 0.42 at least on 100,000 potentials of each generator
#: (``benchmarks/promise/domain_walls.py``), divided by 1.25 (the slack of
#: :func:`fit_domain`). A wall that does not push inward is no wall: from rest there, a
#: particle stays or leaves [0, 1], and no training trajectory did.
GENERATOR_DOMAIN = {"V_range": (-V0, V0), "max_slope": 80.0,
                    "min_V_at_most": 2.0 / 9.0 + 80.0 / 198.0, "max_curvature": 3200.0,
                    "min_wall_force": 0.42 / 1.25}

_WIDTH = SENSORS[1] - SENSORS[0]  # a NumPy float64, as the bounds were computed with
# the slope away from a wall at its sensor, into [0, 1], from the cubic through the four
# sensors there: V'(0), and -V'(1) at q = 1 (the rows reversed)
_WALL_WEIGHTS = np.array([-11.0, 18.0, -9.0, 2.0]) / (6.0 * _WIDTH)


def domain_violations(V, domain=None):
    """Why sensor values lie outside what the paper's generator produces.

    A network trained on the generator's potentials has never seen such inputs; its
    outputs there are extrapolation. Call this before predicting and raise
    :class:`OutOfDomainWarning` with each message.

    Args:
        V: sensor values, shape (100,) or (N, 100), or a potential with ``V(q)``.
        domain: bounds as in :data:`GENERATOR_DOMAIN` (the default).

    Returns:
        list of messages, one per violated bound, each naming the rows (for a batch),
        the worst value and the bound; empty when every row is inside.

    Raises:
        ValueError: for a wrong shape or non-finite values.

    Example:
        >>> domain_violations(8 * (SENSORS - 0.5) ** 2)
        []
        >>> domain_violations(2 - 88 * SENSORS * (1 - SENSORS))[0].split(":")[0]
        'V has values below -2 (the generator keeps V in [-2, 2])'

    A batch whose every row is clearly inside is answered by one compiled pass
    (:func:`surely_inside`); statistics and messages are built only otherwise.
    """
    d = GENERATOR_DOMAIN if domain is None else domain
    if not (type(V) is np.ndarray and V.dtype == np.float64):
        V = sensor_values(V)  # read only here: a float64 array needs no copy
    if V.ndim in (1, 2) and V.shape[-1] == SENSORS.size and V.size and surely_inside(
            np.ascontiguousarray(V.reshape(-1, SENSORS.size)), *_bounds(d)):
        return []  # the usual case, in one compiled pass: no statistics kept, no message
    if V.ndim not in (1, 2) or V.shape[-1] != SENSORS.size or not np.all(np.isfinite(V)):
        raise ValueError(f"V must hold finite values at the {SENSORS.size} sensors, shape "
                         f"(100,) or (N, 100); got shape {V.shape}")
    rows = np.atleast_2d(V)
    stats = domain_stats(rows)
    lo, hi = d["V_range"]
    source = d.get("source", "the generator")
    checks = [
        (stats["min"], lambda x: x < lo - 1e-9, np.argmin,
         f"has values below {lo:g} ({source} keeps V in [{lo:g}, {hi:g}])", "min V"),
        (stats["max"], lambda x: x > hi + 1e-9, np.argmax,
         f"has values above {hi:g} ({source} keeps V in [{lo:g}, {hi:g}])", "max V"),
        (stats["min"], lambda x: x > d["min_V_at_most"], np.argmax,
         f"never dips below {d['min_V_at_most']:.3g} (every potential of {source} does: "
         "too flat)", "min V"),
        (stats["slope"], lambda x: x > d["max_slope"], np.argmax,
         f"is steeper than {source}'s max |V'| = {d['max_slope']:g}", "max |ΔV/Δq|"),
        (stats["curvature"], lambda x: x > d["max_curvature"], np.argmax,
         f"curves more sharply than {source} (|V''| ≤ {d['max_curvature']:g} "
         "at the sensors)", "max |Δ²V/Δq²|"),
    ]
    bound = d["min_wall_force"]
    checks.append((stats["wall_force"], lambda x: _weak_walls(x, bound), np.argmin,
                   f"has a wall whose force does not point inward as firmly as in "
                   f"{source} (-V'(0) and V'(1) > {bound:.3g}; from rest there a "
                   "particle stays or leaves [0, 1])", "weakest wall force"))
    messages = []
    for values, bad, pick, text, what in checks:
        hits = np.flatnonzero(bad(values))
        if hits.size:
            worst = hits[pick(values[hits])]
            where = "V" if V.ndim == 1 else (
                f"V[{', '.join(map(str, hits[:5]))}{' ...' if hits.size > 5 else ''}] "
                f"({hits.size} of {len(rows)} rows)")
            messages.append(f"{where} {text}: {what} = {values[worst]:.4g}"
                            + ("" if V.ndim == 1 else f" in row {worst}"))
    return messages


def domain_stats(rows):
    """What a domain bounds, per row of sensor values (N, 100): ``min``, ``max``,
    ``slope`` (``max |ΔV/Δq|``), ``curvature`` (``max |Δ²V/Δq²|``) and ``wall_force``
    (the weaker of the two, :func:`wall_forces`); for :func:`in_domain` against several
    domains.

    Example:
        >>> s = domain_stats(8 * (SENSORS[None] - 0.5) ** 2)
        >>> round(float(s["min"][0]), 4), round(float(s["wall_force"][0]), 6)
        (0.0002, 8.0)
    """
    rows = np.asarray(rows)
    if (rows.ndim != 2 or rows.shape[0] == 0 or rows.shape[1] < 3
            or rows.dtype != np.float64):  # the plain reductions
        first = np.diff(rows, axis=1)
        return {"min": rows.min(axis=1), "max": rows.max(axis=1),
                "slope": np.abs(first).max(axis=1) / _WIDTH,
                "curvature": np.abs(np.diff(first, axis=1)).max(axis=1) / _WIDTH**2,
                "wall_force": wall_forces(rows).min(axis=1)}
    # Row by row, numpy reduces a short axis (100 values) at a fraction of its flat speed:
    # the differences' maxima come from one compiled pass over the rows (the same
    # subtractions as np.diff, and max is exact in any order), the minima and maxima of
    # C-ordered rows from ``reduceat`` over the flat array (numpy's own loop, so the sign of
    # a zero is numpy's too).
    n, m = rows.shape
    maxima = np.empty((2, n))
    difference_maxima(np.ascontiguousarray(rows), maxima)
    if rows.flags.c_contiguous:
        flat, starts = rows.reshape(-1), np.arange(0, n * m, m)
        low, high = np.minimum.reduceat(flat, starts), np.maximum.reduceat(flat, starts)
    else:
        low, high = rows.min(axis=1), rows.max(axis=1)
    walls = wall_forces(rows)
    return {"min": low, "max": high, "slope": maxima[0] / _WIDTH,
            "curvature": maxima[1] / _WIDTH**2,
            "wall_force": np.minimum(walls[:, 0], walls[:, 1])}


@numba.njit(**JIT)
def difference_maxima(rows: np.ndarray, out: np.ndarray) -> None:
    """``max |ΔV|`` and ``max |Δ²V|`` of each row, into ``out[0]`` and ``out[1]``.

    Two rows at a time (two independent chains of maxima run about twice as fast as
    one); the last of an odd number is paired with itself.

    Args:
        rows: float64 (N, m), m ≥ 3, C-contiguous.
        out: float64 (2, N), written.
    """
    n, m = rows.shape
    for i in range(0, n, 2):
        a, b = rows[i], rows[min(i + 1, n - 1)]
        da, db = a[1] - a[0], b[1] - b[0]
        sa, sb, ca, cb = abs(da), abs(db), 0.0, 0.0
        for j in range(2, m):
            ea, eb = a[j] - a[j - 1], b[j] - b[j - 1]
            sa, sb = max(sa, abs(ea)), max(sb, abs(eb))
            ca, cb = max(ca, abs(ea - da)), max(cb, abs(eb - db))
            da, db = ea, eb
        out[0, i], out[1, i] = sa, ca
        if i + 1 < n:
            out[0, i + 1], out[1, i + 1] = sb, cb


def _bounds(d: dict) -> tuple:
    """The arguments of :func:`surely_inside` for the domain ``d``, as floats: each bound
    in the form the checks of :func:`domain_violations` compare with."""
    lo, hi = d["V_range"]
    return (float(lo - 1e-9), float(hi + 1e-9), float(d["min_V_at_most"]),
            float(d["max_slope"]), float(d["max_curvature"]),
            max(float(d["min_wall_force"]), 0.0), float(_WIDTH), float(_WIDTH**2),
            _WALL_WEIGHTS)


@numba.njit(**JIT)
def surely_inside(rows: np.ndarray, low: float, high: float, min_at_most: float,
                  max_slope: float, max_curvature: float, min_wall: float, width: float,
                  width2: float, weights: np.ndarray) -> bool:
    """Whether every row passes every check of :func:`domain_violations`, sure of it.

    The statistics of :func:`domain_stats`, compared with the bounds as ``in_domain`` does
    (the same subtractions and divisions, so the same outcome), row by row, two rows at a
    time, stopping at the first row that fails. The wall forces are dot products, whose
    rounding depends on the order of the sum (numpy's BLAS may use another): a row passes
    that check only when its force clears the bound by 1e-13 of the sum of the products'
    magnitudes, far beyond what any order of a four-term sum rounds; a row closer than
    that is left to the exact path. A NaN passes no comparison.

    Args:
        rows: float64 (N, m), C-contiguous, m ≥ 4.
        low, high: the V range, widened by 1e-9.
        min_at_most, max_slope, max_curvature: the domain's bounds.
        min_wall: the wall bound, at least 0 (a force must also be > 0).
        width, width2: the sensor spacing and its square, as ``domain_stats`` divides.
        weights: (4,) the weights of :func:`wall_forces`.

    Returns:
        bool: True when every row is inside; False when one is not or is too close to call.
    """
    n, m = rows.shape
    for i in range(0, n, 2):
        a, b = rows[i], rows[min(i + 1, n - 1)]
        la, lb, ha, hb = min(a[0], a[1]), min(b[0], b[1]), max(a[0], a[1]), max(b[0], b[1])
        ta, tb = a[0] + a[1], b[0] + b[1]  # sums: finite unless a value is NaN or ±inf
        da, db = a[1] - a[0], b[1] - b[0]
        sa, sb, ca, cb = abs(da), abs(db), 0.0, 0.0
        for j in range(2, m):
            xa, xb = a[j], b[j]
            la, lb, ha, hb = min(la, xa), min(lb, xb), max(ha, xa), max(hb, xb)
            ta, tb = ta + xa, tb + xb
            ea, eb = xa - a[j - 1], xb - b[j - 1]
            sa, sb = max(sa, abs(ea)), max(sb, abs(eb))
            ca, cb = max(ca, abs(ea - da)), max(cb, abs(eb - db))
            da, db = ea, eb
        for lo_, hi_, s, c, t, r in ((la, ha, sa, ca, ta, a), (lb, hb, sb, cb, tb, b)):
            if not (t - t == 0.0 and lo_ >= low and hi_ <= high and lo_ <= min_at_most
                    and s / width <= max_slope and c / width2 <= max_curvature):
                return False
            for k in range(2):
                force, scale = 0.0, 0.0
                for w in range(4):
                    term = r[w if k == 0 else m - 1 - w] * weights[w]
                    force -= term
                    scale += abs(term)
                if not force > min_wall + 1e-13 * scale:
                    return False
    return True


def _weak_walls(force, bound):
    return (force <= 0.0) | (force < bound)


def wall_forces(V):
    """The inward force at each wall, -V'(0) and V'(1), from the cubic through the four
    sensors next to it (third order in the sensor spacing).

    Args:
        V: sensor values, shape (N, 100) (or (100,)).

    Returns:
        (N, 2) (or (2,)): positive where the force pushes a particle back into [0, 1].

    Example:
        >>> np.round(wall_forces(8 * (SENSORS - 0.5) ** 2), 6).tolist()  # V'(0) = -8
        [8.0, 8.0]
    """
    V = np.asarray(V, dtype=np.float64)
    rows = np.atleast_2d(V)
    out = -np.stack([rows[:, :4] @ _WALL_WEIGHTS, rows[:, :-5:-1] @ _WALL_WEIGHTS], axis=1)
    return out if V.ndim == 2 else out[0]


def in_domain(V, domain=None, *, stats=None):
    """Which rows of sensor values pass every check of :func:`domain_violations`.

    Args:
        V: sensor values, shape (N, 100) (or (100,)), finite.
        domain: bounds as in :data:`GENERATOR_DOMAIN` (the default) or from
            :func:`fit_domain`.
        stats: :func:`domain_stats` of V, if already computed.

    Returns:
        bool array (N,) (a 0-d bool for one row).

    Example:
        >>> in_domain(np.stack([8 * (SENSORS - 0.5) ** 2, 2 - 88 * SENSORS * (1 - SENSORS)]))
        array([ True, False])
    """
    d = GENERATOR_DOMAIN if domain is None else domain
    V = np.asarray(V, dtype=np.float64)
    stats = domain_stats(np.atleast_2d(V)) if stats is None else stats
    ok = _inside(stats, d)
    return ok if V.ndim == 2 else ok[0]


def _inside(stats: dict, d: dict) -> np.ndarray:
    """Rows of :func:`domain_stats` within every bound of the domain ``d`` (bool (N,)):
    each test the negation of one check of :func:`domain_violations` (values finite)."""
    lo, hi = d["V_range"]
    return ((stats["min"] >= lo - 1e-9) & (stats["max"] <= hi + 1e-9)
            & (stats["min"] <= d["min_V_at_most"]) & (stats["slope"] <= d["max_slope"])
            & (stats["curvature"] <= d["max_curvature"])
            & ~_weak_walls(stats["wall_force"], d["min_wall_force"]))


def fit_domain(V, *, slack=0.25, source="its training data"):
    """A domain fitted to training data: the bounds its sensor values stay within.

    Each bound is the training set's extreme widened by ``slack``: the V range by
    ``slack`` × 0.1 of its width on each side, the slope and curvature bounds by a
    factor 1 + ``slack``, ``min_V_at_most`` (the highest minimum of a row) by
    ``slack`` × its distance to V0, capped at V0, and ``min_wall_force`` (the weakest
    inward wall force, :func:`wall_forces`, never below 0) divided by 1 + ``slack``. A
    network trained on these rows has seen nothing beyond them.

    Args:
        V: the training rows' sensor values, shape (N, 100), N ≥ 1.
        slack: relative widening (≥ 0; default 0.25).
        source: how messages of :func:`domain_violations` name the data.

    Returns:
        dict with the keys of :data:`GENERATOR_DOMAIN`, plus ``source`` and ``rows``.

    Raises:
        ValueError: for a wrong shape, non-finite values or a negative slack.

    Example:
        >>> d = fit_domain(np.stack([8 * (SENSORS - 0.5) ** 2, 2 - 8 * SENSORS * (1 - SENSORS)]))
        >>> [round(v, 2) for v in d["V_range"]], round(d["min_V_at_most"], 2)
        ([-0.05, 2.05], 0.5)
    """
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or V.shape[1] != SENSORS.size or len(V) == 0 or not np.all(np.isfinite(V)):
        raise ValueError(f"V must hold finite values at the {SENSORS.size} sensors, shape "
                         f"(N, 100) with N ≥ 1; got shape {V.shape}")
    if not slack >= 0:
        raise ValueError(f"slack must be ≥ 0, got {slack!r}")
    stats = domain_stats(V)
    lo, hi = float(stats["min"].min()), float(stats["max"].max())
    pad = 0.1 * slack * (hi - lo)
    highest_min = float(stats["min"].max())
    return {"V_range": (lo - pad, hi + pad),
            "max_slope": (1 + slack) * float(stats["slope"].max()),
            "min_V_at_most": min(V0, highest_min + slack * max(V0 - highest_min, 0.0)),
            "max_curvature": (1 + slack) * float(stats["curvature"].max()),
            "min_wall_force": max(float(stats["wall_force"].min()), 0.0) / (1 + slack),
            "source": source, "rows": len(V)}
