"""The generator's domain: what its potentials look like at the sensors.

A network trained on the generator's potentials has never seen sensor values outside
these bounds; its outputs there are extrapolation. :func:`domain_violations` says why an
input lies outside, and :class:`OutOfDomainWarning` carries the reasons.
"""

import numpy as np

from .._constants import SENSORS, V0
from .._sensors import sensor_values

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
    """
    d = dict(GENERATOR_DOMAIN if domain is None else domain)
    V = sensor_values(V)
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
    width = SENSORS[1] - SENSORS[0]
    first = np.diff(rows, axis=1)  # np.diff(rows, 2) is the diff of this: computed once
    return {"min": rows.min(axis=1), "max": rows.max(axis=1),
            "slope": np.abs(first).max(axis=1) / width,
            "curvature": np.abs(np.diff(first, axis=1)).max(axis=1) / width**2,
            "wall_force": wall_forces(rows).min(axis=1)}


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
    width = SENSORS[1] - SENSORS[0]
    # the slope away from a wall at its sensor, into [0, 1]: V'(0), and -V'(1) at q = 1
    weights = np.array([-11.0, 18.0, -9.0, 2.0]) / (6.0 * width)
    out = -np.stack([rows[:, :4] @ weights, rows[:, :-5:-1] @ weights], axis=1)
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
    lo, hi = d["V_range"]
    ok = ((stats["min"] >= lo - 1e-9) & (stats["max"] <= hi + 1e-9)
          & (stats["min"] <= d["min_V_at_most"]) & (stats["slope"] <= d["max_slope"])
          & (stats["curvature"] <= d["max_curvature"])
          & ~_weak_walls(stats["wall_force"], d["min_wall_force"]))
    return ok if V.ndim == 2 else ok[0]


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
