"""Any horizon at the cost of one period: every bounded 1-D orbit is periodic.

For a row whose latest time exceeds :data:`PERIODIC_FROM`, the period T of its orbit is
found once (:mod:`._orbit`: turning points, then an adaptive quadrature of dq/|p|, with
an error bound δT, to the accuracy the horizon needs: its phase error at the latest time
may cost :data:`PHASE_SHARE` of the tolerance, and T is never coarser than 1e-9 nor
finer than 1e-14 relative), and every time t = n T + r is answered by
the solve at r ∈ [0, T). The time T itself is solved too: the trajectory must return to
its starting state there, a check that catches a period gone wrong (a barrier narrower
than the search grid of the turning points).

**Phase error.** An error δT of the period shifts the answer at t by n δT, and the
rounding of t in float64 adds its spacing ulp(t). To first order the state moves by
(p, −V′) times that shift, so the phase adds mean((n δT + ulp(t))² (p² + V′²)) / 2 to
L_tot, evaluated at the solution (:func:`phase_error`); it is part of the returned
estimate, and the solve itself runs to the rest of the tolerance (set beforehand with
S, a bound on p² + V′² along the orbit).

**Refusals.** A time whose float64 spacing alone costs more than a quarter of the
tolerance is beyond what float64 resolves (a :class:`~.row_error.RowError`). A period
that cannot be found (the orbit passes at zero speed over a barrier top, a separatrix,
where T → ∞) or whose phase error exceeds a quarter of the tolerance raises
:class:`PeriodError` when the latest time exceeds :data:`DIRECT_HORIZON`; up to there the
orbit is integrated directly. Both name the row of a batch (``row``).
"""

import math
from dataclasses import dataclass

import numpy as np

from .._constants import TIMES
from ._orbit import BARRIER, NOT_CONVERGED, batch_orbit_period, orbit_period
from ._reduce import BEYOND, LOOSE_FAR, plan_rows
from .row_error import RowError

__all__ = ["DIRECT_HORIZON", "PERIODIC_FROM", "HorizonPlan", "PeriodError", "PeriodShift",
           "orbit_periods", "plan_horizon"]

#: Rows whose latest time exceeds this are answered from one period.
PERIODIC_FROM = 2.0
#: Without a usable period, rows up to this time are integrated directly.
DIRECT_HORIZON = 50.0

#: A period whose error bound exceeds this share of T is not used.
_LOOSE = 1e-8
#: The share of the tolerance that the error of T may cost at the latest time; the
#: quadrature aims for it (then the solve keeps (1 - sqrt(1/400))² = 90 % of tol).
PHASE_SHARE = 1.0 / 400.0

_FAILURES = {NOT_CONVERGED: "its period quadrature did not converge",
             BARRIER: "it turns around where V' (almost) vanishes, or V reaches the "
                      "energy between its turning points"}


class PeriodError(RowError):
    """The period of an orbit cannot be found to the accuracy the tolerance needs.

    A :class:`~nh_operators.solvers.row_error.RowError` (so a ``ValueError``): ``row``
    names the row of a batch, or is None for a single solve.
    """


@dataclass(frozen=True)
class PeriodShift:
    """The phase data of a plan in which some row's horizon exceeds :data:`PERIODIC_FROM`
    (final): what :func:`phase_error` needs to measure the phase error at the solution.

    Attributes:
        shift: (N, M) per sorted asked time, the shift n δT + ulp(t) that the error of T
            and the rounding of t cause (0 in rows not answered from one period).
        period_error: (K,) the error bound δT of the period of each row of ``rows``.
        rows: (K,) int64, the rows whose latest time exceeds :data:`PERIODIC_FROM`.
        horizon: (N,) the latest asked time of every row.
    """

    shift: np.ndarray
    period_error: np.ndarray
    rows: np.ndarray
    horizon: np.ndarray


@dataclass(frozen=True)
class HorizonPlan:
    """The working times of a solve, from :func:`plan_horizon` (final).

    Attributes:
        work: (N, M), or (N, M + 1) when ``column`` is set: sorted working times.
        column: (N, M + 1) int64, the sorted working column of each asked time, then of
            T; None when no row's horizon exceeds :data:`PERIODIC_FROM` (``work`` is then
            the asked times).
        periodic: (N,) bool, the rows answered from one period (or standing still).
        period: (N,) the period T of each row answered from one, nan elsewhere.
        phase: (N,) the bound on the phase part of L_tot that the solve leaves room for.
        shifts: the phase data when ``column`` is set, else None.
    """

    work: np.ndarray
    column: np.ndarray | None
    periodic: np.ndarray
    period: np.ndarray
    phase: np.ndarray
    shifts: PeriodShift | None = None


def orbit_periods(src, rows, q0s, p0s, rate=None):
    """Period data of rows ``rows`` of a row source (:mod:`.rows`).

    Args:
        src: a row source (force, value, params, compiled).
        rows: (K,) int64 indices of the rows.
        q0s, p0s: (N,) starting states of all rows.
        rate: (K,) per row, the drift of the state per unit time that the error of T
            may cause (T is then aimed at rate / sqrt(max(p² + V′²)) relative), or None
            for the finest T (:data:`~._orbit.REL_FINEST`, about 1e-14, relative).

    Returns:
        (out, status): out (K, 7) holds T, δT, a, b, S, E and the q where the quadrature
        peaked; status (K,) the codes of :mod:`._orbit` (0: found).

    Example:
        >>> from nh_operators.solvers.rows import row_source
        >>> src = row_source("sho", "exact V")
        >>> out, status = orbit_periods(src, np.array([0]), np.array([0.0]), np.array([0.0]))
        >>> int(status[0]), round(float(out[0, 0]), 12)  # T = π/2
        (0, 1.570796326795)
    """
    out = np.empty((rows.size, 7))
    status = np.empty(rows.size, dtype=np.int64)
    rate = np.zeros(rows.size) if rate is None else np.ascontiguousarray(rate, np.float64)
    if src.compiled:
        batch_orbit_period(src.value, src.force, src.params, rows, q0s, p0s, rate,
                           out, status)
    else:
        for k, i in enumerate(rows):
            status[k] = orbit_period(src.value, src.force, src.params[0], q0s[i],
                                     p0s[i], rate[k], out[k])
    return out, status


def _row(batched, i):
    """The row to name in an error: ``i`` in a batch, else None (no prefix)."""
    return int(i) if batched else None


def plan_horizon(src, ts, q0s, p0s, tols, batched=False) -> HorizonPlan:
    """Working times of each row: reduced into one period where the horizon needs it.

    Args:
        src: a row source; ts: (N, M) sorted asked times; q0s, p0s: (N,); tols: (N,)
            tolerances on L_tot; batched: name rows in messages.

    Returns:
        :class:`HorizonPlan`: ``column`` and ``shifts`` are None when no row's latest
        time exceeds :data:`PERIODIC_FROM`.

    Raises:
        RowError: a time beyond what float64 resolves.
        PeriodError: no usable period for a row whose horizon exceeds DIRECT_HORIZON.
    """
    n, m = ts.shape
    period = np.full(n, np.nan)
    phase = np.zeros(n)
    periodic = np.zeros(n, dtype=bool)
    need = np.flatnonzero(ts[:, -1] > PERIODIC_FROM)
    if need.size == 0:
        return HorizonPlan(ts, None, periodic, period, phase)
    # L_tot of a shift s is about s² S / 2: allow PHASE_SHARE · tol at the latest time
    rate = np.sqrt(2.0 * PHASE_SHARE * tols[need]) / ts[need, -1]
    out, status = orbit_periods(src, need, q0s, p0s, rate)
    work = np.concatenate([ts, ts[:, -1:]], axis=1)
    column = np.empty(work.shape, dtype=np.int64)
    column[:] = np.arange(m + 1)  # rows without a period keep their (sorted) order
    shifts = np.zeros((n, m))
    verdict = np.empty(need.size, dtype=np.int64)
    plan_rows(np.ascontiguousarray(ts), tols, need, out, status, _LOOSE,
              DIRECT_HORIZON, work, column, shifts, phase, period, periodic, verdict)
    if verdict.max() >= BEYOND:
        _refuse(ts, tols, q0s, p0s, need, out, status, verdict, batched)
    return HorizonPlan(work, column, periodic, period, phase,
                       PeriodShift(shifts, out[:, 1], need, ts[:, -1]))


def _refuse(ts, tols, q0s, p0s, need, out, status, verdict, batched):
    """Raise for the first row that cannot be answered (a verdict of BEYOND first)."""
    T, dT, _, _, S, energy, peak = out.T
    beyond = np.flatnonzero(verdict == BEYOND)
    if beyond.size:
        k = beyond[0]
        tmax = ts[need[k], -1]
        ulp = np.spacing(tmax)
        with np.errstate(over="ignore"):
            rounding = 0.5 * S[k] * ulp**2
        raise RowError(
            f"t = {tmax:g} is beyond what float64 resolves: "
            f"the spacing of float64 numbers there is {ulp:.3g}, which at speeds up to "
            f"{math.sqrt(S[k]):.3g} moves the state by {math.sqrt(S[k]) * ulp:.3g} (L_tot "
            f"{rounding:.3g}), more than tol {tols[need[k]]:g} allows",
            row=_row(batched, need[k]))
    k = int(np.flatnonzero(verdict >= LOOSE_FAR)[0])
    i = need[k]
    orbit = f"the orbit from (q0 = {q0s[i]:g}, p0 = {p0s[i]:g}), energy {energy[k]:.10g}"
    if verdict[k] == LOOSE_FAR:
        raise PeriodError(
            f"the period T = {T[k]:.6g} of {orbit}, is only known to "
            f"±{dT[k]:.2g}: it passes near q = {peak[k]:.6g} at almost zero speed, close "
            f"to a separatrix, where T → ∞; times up to {DIRECT_HORIZON:g} are integrated "
            "directly", row=_row(batched, i))
    raise PeriodError(
        f"the period of {orbit}, cannot be found: "
        f"{_FAILURES[status[k]]} near q = {peak[k]:.6g}. The particle passes a barrier top "
        f"at (almost) zero speed, a separatrix, where T → ∞; times up to "
        f"{DIRECT_HORIZON:g} are integrated directly", row=_row(batched, i))


def phase_error(src, plan: HorizonPlan, q, p, tols, batched=False) -> np.ndarray:
    """The phase part of L_tot at the solution: mean((n δT + ulp)² (p² + V′²)) / 2, (N,).

    Args:
        src: the row source of the solve; plan: its :class:`HorizonPlan`.
        q, p: (N, M) the states at the asked times, in the sorted order of the plan.
        tols: (N,) tolerances on L_tot; batched: name rows in messages.

    Returns:
        (N,) the phase part of L_tot; ``plan.phase`` when the plan has no ``shifts``.

    Raises:
        PeriodError: where the phase part exceeds a quarter of the tolerance.
    """
    if plan.shifts is None:  # no row answered from one period
        return plan.phase
    shifts = plan.shifts
    shift = shifts.shift
    rows = np.flatnonzero(shift.any(axis=1))
    phase = plan.phase.copy()  # rows without a shift keep theirs (0, or a tiny orbit's)
    if rows.size:
        force = src.subset(rows).forces_at(q[rows]) if src.params.shape[0] > 1 else \
            src.forces_at(q[rows])
        phase[rows] = 0.5 * np.mean(shift[rows] ** 2 * (p[rows] ** 2 + force**2), axis=1)
    bad = np.flatnonzero(phase > 0.25 * tols)
    if bad.size:
        i = bad[0]
        k = int(np.flatnonzero(shifts.rows == i)[0])
        raise PeriodError(
            f"the period T = {plan.period[i]:.15g} is known to "
            f"±{shifts.period_error[k]:.2g}; by t = {shifts.horizon[i]:g} that shifts "
            f"the phase by up to {shift[i].max():.2g}, L_tot {phase[i]:.2g}, more than a "
            f"quarter of tol {tols[i]:g} (T is hard to pin down where the particle is slow: "
            "near a separatrix, or near a gentle turning point, where E − V(q) is as "
            "small as its own rounding)", row=_row(batched, i))
    return phase


def default_interval(ts, periodic):
    """Output interval per row (see :func:`~nh_operators.integrate`), (N,).

    The spacing of the asked times when they are an even grid from 0, else the spacing
    of :data:`TIMES`. A row answered from one period whose asked times are an even grid
    of m times gets 2 / (m - 1): the spacing of the same scene on [0, 2], so that its
    substep levels are the ones a solve on [0, 2] goes through.
    """
    n, m = ts.shape
    if n == 1 and m >= 2:  # one row (a single solve): the same rule on scalars, cheaper
        gaps = ts[0, 1:] - ts[0, :-1]
        g0 = float(gaps[0])
        if _even_grid(float(ts[0, 0]), g0, float(gaps.max()), float(gaps.min())):
            return np.array([TIMES[-1] / (m - 1) if periodic[0] else g0])
        return np.array([TIMES[1] - TIMES[0]])
    interval = np.full(n, TIMES[1] - TIMES[0])
    if m >= 2:
        gaps = np.diff(ts, axis=1)
        g0 = gaps[:, 0]
        even = _even_grid(ts[:, 0], g0, gaps.max(axis=1), gaps.min(axis=1))
        interval[even] = np.where(periodic[even], TIMES[-1] / (m - 1), g0[even])
    return interval


def _even_grid(first, g0, longest, shortest):
    """Whether times from ``first`` with first gap ``g0`` and gaps between ``shortest``
    and ``longest`` are an even grid from 0 (every gap within 1e-9 · g0 of g0); scalars,
    or (N,) arrays of rows."""
    tol = 1e-9 * g0
    return (first == 0.0) & (g0 > 0) & (longest - g0 <= tol) & (g0 - shortest <= tol)
