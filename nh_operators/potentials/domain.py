"""The generator's domain: what its potentials look like at the sensors.

A network trained on the generator's potentials has never seen sensor values outside
these bounds; its outputs there are extrapolation. :func:`domain_violations` says why an
input lies outside, and :class:`OutOfDomainWarning` carries the reasons.
"""

import numpy as np

from .._constants import SENSORS, V0
from .._sensors import sensor_values

__all__ = ["GENERATOR_DOMAIN", "OutOfDomainWarning", "domain_violations"]


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
#: those 14,000 (99.9th percentile 1,999), times 1.5.
GENERATOR_DOMAIN = {"V_range": (-V0, V0), "max_slope": 80.0,
                    "min_V_at_most": 2.0 / 9.0 + 80.0 / 198.0, "max_curvature": 3200.0}


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
    lo, hi = d["V_range"]
    width = SENSORS[1] - SENSORS[0]
    checks = [
        (rows.min(axis=1), lambda x: x < lo - 1e-9, np.argmin,
         f"has values below {lo:g} (the generator keeps V in [{lo:g}, {hi:g}])", "min V"),
        (rows.max(axis=1), lambda x: x > hi + 1e-9, np.argmax,
         f"has values above {hi:g} (the generator keeps V in [{lo:g}, {hi:g}])", "max V"),
        (rows.min(axis=1), lambda x: x > d["min_V_at_most"], np.argmax,
         f"never dips below {d['min_V_at_most']:.3g} (every generator potential does: too "
         "flat)", "min V"),
        (np.abs(np.diff(rows, axis=1)).max(axis=1) / width, lambda x: x > d["max_slope"],
         np.argmax, f"is steeper than the generator's max |V'| = {d['max_slope']:g}",
         "max |ΔV/Δq|"),
        (np.abs(np.diff(rows, 2, axis=1)).max(axis=1) / width**2,
         lambda x: x > d["max_curvature"], np.argmax,
         f"curves more sharply than the training data (|V''| ≤ {d['max_curvature']:g} "
         "at the sensors)", "max |Δ²V/Δq²|"),
    ]
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
