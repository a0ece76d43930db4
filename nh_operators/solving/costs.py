"""How a calibrated cost scales with the horizon of a call.

Costs come from a shipped model's calibration
(:class:`~nh_operators.solving.calibration.Calibration`, measured by
:func:`~nh_operators.solving.calibrate_pretrained` on the machine that calibrated it):
one call's seconds, per-row seconds inside ``solve_many``, the classical ones per kind of
input and per tolerance, and the classical ones for a short horizon.
"""

import math

import numpy as np

from .._constants import TIMES

__all__ = ["SHORT_HORIZON", "horizon_key", "horizon_share"]

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
