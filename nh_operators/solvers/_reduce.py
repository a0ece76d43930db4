"""Compiled bookkeeping of :func:`.periodic.plan_horizon`: each row's verdict on its
period, and its asked times reduced into one period, in one numba call.

A far scene's classical solve is cheap (one period), so the Python and NumPy overhead of
planning it (some 40 small array operations, ~100 µs) would otherwise be most of the
extra cost of a far horizon over [0, 2].
"""

import math

import numba
import numpy as np

from ..potentials._spline_kernels import JIT
from ._orbit import OK, STATIONARY

#: Verdicts of :func:`plan_rows`, per row.
USE, STILL, DIRECT, BEYOND, LOOSE_FAR, FAILED_FAR = 0, 1, 2, 3, 4, 5


@numba.njit(**JIT)
def ulp(x):
    """The spacing of float64 numbers at |x| (``np.spacing`` for finite x ≥ 0)."""
    x = abs(x)
    if x == 0.0:
        return 5e-324
    if not math.isfinite(x):
        return math.inf
    e = math.frexp(x)[1]
    return math.ldexp(1.0, max(e - 53, -1074))


@numba.njit(**JIT)
def plan_rows(ts, tols, need, out, status, loose, direct_horizon, work, column, shifts,
              phase, period, periodic, verdict):
    """Fill the plan of rows ``need`` (see :func:`.periodic.plan_horizon`).

    Args:
        ts: (N, M) sorted asked times; tols: (N,); need: (K,) rows with a far horizon;
        out, status: (K, 7) and (K,) from :func:`._orbit.batch_orbit_period`;
        loose: a period known worse than this share of T is not used;
        direct_horizon: without a usable period, rows up to this time are integrated
            directly.
        work (N, M + 1): each row of ``need`` reduced into one period, then sorted;
        column (N, M + 1) int64: the sorted column each unsorted one went to;
        shifts (N, M), phase, period, periodic (N,): written for the rows of ``need``;
        verdict (K,): one of USE, STILL, DIRECT, BEYOND (a time finer than float64
            resolves), LOOSE_FAR, FAILED_FAR (no usable period and a horizon beyond
            ``direct_horizon``).
    """
    m = ts.shape[1]
    for k in range(need.shape[0]):
        i = need[k]
        T = out[k, 0]
        dT = out[k, 1]
        S = out[k, 4]
        tol = tols[i]
        tmax = ts[i, m - 1]
        spacing = ulp(tmax)
        if (0.5 * S * spacing * spacing > 0.25 * tol
                or not math.isfinite(tmax / max(T, 1e-300))):
            verdict[k] = BEYOND
            continue
        found = status[k] == OK
        vague = found and dT > loose * T
        # an orbit smaller than the tolerance (at rest at, or next to, an equilibrium):
        # its starting state is the answer at every time, within (b - a)² + max p²
        tiny = 0.5 * ((out[k, 3] - out[k, 2]) ** 2 + S)
        if status[k] == STATIONARY or ((not found or vague) and tiny <= 0.25 * tol):
            work[i, :] = 0.0  # the state never changes (by more than the bound)
            periodic[i] = True
            phase[i] = 0.0 if status[k] == STATIONARY else tiny
            verdict[k] = STILL
            continue
        if not found or vague:
            if tmax <= direct_horizon:
                verdict[k] = DIRECT
            else:
                verdict[k] = LOOSE_FAR if vague else FAILED_FAR
            continue
        total = 0.0
        for j in range(m):
            t = ts[i, j]
            turns = math.floor(t / T)
            reduced = t - turns * T
            if reduced < 0.0:
                turns -= 1.0
            elif reduced >= T:
                turns += 1.0
            work[i, j] = min(max(t - turns * T, 0.0), T)
            shift = turns * dT + ulp(t)
            shifts[i, j] = shift
            total += shift * shift
        work[i, m] = T
        # a bound (S: max of p² + V'² on the orbit) that sets the solve's share of tol;
        # the phase error itself is measured at the solution (.periodic.phase_error)
        phase[i] = min(0.5 * S * total / m, 0.25 * tol)
        period[i] = T
        periodic[i] = True
        verdict[k] = USE
        order = np.argsort(work[i], kind="mergesort")
        work[i] = work[i][order]
        for j in range(m + 1):
            column[i, order[j]] = j
