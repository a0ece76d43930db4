"""What ``solve`` weighs: the calibrated cost of a network and of the classical solve.

Costs come from a shipped model's ``calibration.json`` (measured by
:func:`~nh_operators.solving.calibrate_pretrained` on the machine that calibrated it):
one call's seconds, per-row seconds inside ``solve_many``, the classical ones per kind of
input and per tolerance, and the classical ones for a short horizon.
"""

import math

import numpy as np

from .._constants import TIMES

__all__ = ["SHORT_HORIZON", "horizon_share"]

#: The latest time of the calibration's short classical timing (the other is the grid's
#: end, t = 2).
SHORT_HORIZON = 0.5

#: Which of the calibration's classical timings applies to a kind of input.
_TIMINGS = {"bspline": "classical_seconds", "sensors": "classical_seconds_sensors",
            "formula": "classical_seconds_formula"}


def _input_kind(pot, information):
    from ..potentials import BoundedPotential

    if information == "sensors":
        return "sensors"
    return "bspline" if isinstance(pot, BoundedPotential) else "formula"


def _classical_seconds(calibration, tol, kind="bspline", batched=False, horizon=None):
    """The classical solve's calibrated seconds at ``tol`` for an input ``kind``, one
    call's or per row in ``solve_many`` (``batched``), up to the latest time ``horizon``
    (default: the grid's end, where it was measured).

    The calibration measures one call's classical cost on the whole grid (to t = 2) and
    up to :data:`SHORT_HORIZON`; between (and below)
    them the cost is taken linear in the horizon, c0 + (1 − c0) · horizon / 2 of the
    whole grid's, c0 ∈ [0, 1] fitted through the two, and the batched cost scales the
    same way. A calibration without the short timing (older files) weighs the whole
    grid's cost at every horizon."""
    tols = np.log10(calibration["classical_tols"])
    field = _TIMINGS[kind] if _TIMINGS[kind] in calibration else "classical_seconds"
    seconds = calibration[field]
    if batched:  # per row inside solve_many, where calibrated (else one call's)
        seconds = calibration.get(_TIMINGS[kind] + "_batched", seconds)
    at = float(np.interp(-np.log10(tol), -tols, seconds))
    if horizon is None or horizon >= TIMES[-1] or field + "_short" not in calibration:
        return at
    full, short = (float(np.interp(-np.log10(tol), -tols, calibration[f]))
                   for f in (field, field + "_short"))
    return at * horizon_share(short / full, horizon)


def horizon_share(short_share, horizon):
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


def _neural_seconds(calibration, batched=False):
    if batched:
        return calibration.get("neural_seconds_batched", calibration["neural_seconds"])
    return calibration["neural_seconds"]


def _horizon_key(t):
    """The latest asked time, rounded up to 0.1: the horizon a cost is weighed at (a
    coarse key keeps the ranking's cache warm: 0.01 cost 25 µs a call in misses)."""
    return math.ceil(10 * float(np.max(t)) - 1e-9) / 10
