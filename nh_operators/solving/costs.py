"""How a calibrated cost scales with the horizon of a call.

Costs come from a shipped model's calibration
(:class:`~nh_operators.solving.calibration.Calibration`, measured by
:func:`~nh_operators.solving.calibrate_pretrained` on the machine that calibrated it):
one call's seconds, per-row seconds inside ``solve_many``, the classical ones per kind of
input and per tolerance, and the classical ones for a short horizon; and what the
classical solve and the networks measured per row in this process
(:func:`measured_seconds`).
"""

import math

import numpy as np

from .._constants import TIMES

__all__ = ["SHORT_HORIZON", "horizon_key", "horizon_share", "measured_seconds",
           "remember_seconds"]

#: The latest time of the calibration's short classical timing (the other is the grid's
#: end, t = 2).
SHORT_HORIZON = 0.5


def horizon_share(short_share: float, horizon: float) -> float:
    """The classical cost up to ``horizon`` as a share of the whole grid's (t = 2), from
    the measured share ``short_share`` at
    :data:`SHORT_HORIZON`: linear in the horizon, with
    a fixed part c0 ∈ [0, 1].

    Example:
        >>> round(horizon_share(0.5, 0.5), 3), round(horizon_share(0.5, 1.25), 3)
        (0.5, 0.75)
    """
    end = TIMES[-1]
    c0 = min(max((short_share - SHORT_HORIZON / end) / (1 - SHORT_HORIZON / end), 0.0), 1.0)
    return float(c0 + (1 - c0) * min(max(horizon, 0.0), end) / end)


def horizon_key(t: np.ndarray) -> float:
    """The latest asked time, rounded up to 0.1: the horizon a cost is weighed at (a
    coarse key keeps the ranking's cache warm: 0.01 cost 25 µs a call in misses).

    Example:
        >>> horizon_key(np.array([0.1, 0.731]))
        0.8
    """
    return math.ceil(10 * float(np.max(t)) - 1e-9) / 10



#: Seconds per row measured in this process, by the caller's key: ``solve_many``'s
#: classical passes.
_MEASURED: dict[tuple, float] = {}


def remember_seconds(key: tuple, seconds: float) -> None:
    """Record that rows of ``key`` (a classical pass at one tolerance, integrator, input
    kind and horizon) took ``seconds`` per row."""
    _MEASURED[key] = float(seconds)


def measured_seconds(key: tuple, default: float = math.inf) -> float:
    """The seconds per row last recorded for ``key`` (:func:`remember_seconds`), or
    ``default`` where none was.

    ``solve_many``'s pilot takes the smaller of the classical cost recorded so and the
    one it measures on a few rows of its own (a probe of a few rows pays more than its
    share of a call's fixed costs, and a first call may find caches cold: a classical
    cost measured too high would let a network that does not pay go on). Nothing a
    pilot measured of the networks is kept: it belongs to the call's rows.

    Example:
        >>> remember_seconds(("example",), 2e-5)
        >>> measured_seconds(("example",)), measured_seconds(("other",), default=0.0)
        (2e-05, 0.0)
    """
    return _MEASURED.get(key, default)
