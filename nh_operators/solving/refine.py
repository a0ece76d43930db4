"""A finer look where a network's estimate fails: the same estimate on a grid twice as
fine.

The estimate (:func:`~nh_operators.solving.estimate.estimate_at`) integrates the cubic
spline through the prediction at the 100 grid times. Where a trajectory turns sharply
between grid times, that spline, not the prediction, carries the defect, and the
estimate refuses an accurate answer (:doc:`/fast_operator` measures how often). A network
that can answer at any time (a PhaseONet: period and shape in phase) is asked again on
:data:`FINE_TIMES` for the rows its estimate refused, and the estimate there, calibrated
on its own (``factors_fine``, ``factors_sensors_fine``), may accept them. Early calls
(:data:`~nh_operators.solving.acceptance.EARLY_HORIZON`) are not refined; in
``solve_many`` a pilot stops the finer look where what it accepts does not pay for it;
a single ``solve`` does not take it.
"""

import numpy as np

from .._constants import TIMES
from .estimate import estimate_at
from .loader import load

__all__ = ["FINE_TIMES", "REFINE", "fine_estimate", "refines"]

#: How many times finer the second grid is.
REFINE = 2

#: The second grid: :data:`~nh_operators.TIMES` and the midpoints between them.
FINE_TIMES = np.linspace(0.0, TIMES[-1], REFINE * (TIMES.size - 1) + 1)
FINE_TIMES.flags.writeable = False


def refines(name):
    """Whether shipped model ``name`` answers on :data:`FINE_TIMES` as it does on the grid
    (a PhaseONet, whose prediction is a function of time, not a decoder of queries)."""
    from ..models import PhaseONet, StatePhaseONet

    return isinstance(load(name).net, (PhaseONet, StatePhaseONet))


def fine_estimate(name, V, values, slopes, at, q0: float | np.ndarray = 0.0,
                  p0: float | np.ndarray = 0.0):
    """Model ``name``'s prediction for sensor values V (N, 100) from (q0, p0) on
    :data:`FINE_TIMES`, at the asked times ``at``, and its raw estimate there:
    (q, p, raw) as :func:`~nh_operators.solving.estimate.estimate_at` returns them
    (``values``, ``slopes``: the rows' V and dV/dq)."""
    from ..models import predict

    shipped = load(name)
    q, p = predict(shipped.net, shipped.input_rows(V, q0, p0), FINE_TIMES)
    return estimate_at(q, p, values, slopes, at, FINE_TIMES, q0=q0, p0=p0)
