"""The adaptive classical solve of many rows at once: one potential per row, own states.

:func:`solve_rows` is the substep doubling of :mod:`.classical_solve`, vectorised over
rows: every level runs the active rows in one parallel numba kernel, and a row leaves as
soon as its own estimate is accepted, so each row gets exactly what a solve of that row
alone would give (same levels, same step grid, same arithmetic). Rows whose horizon
exceeds :data:`~nh_operators.solvers.periodic.PERIODIC_FROM` are answered from one
period (:mod:`.periodic`).
"""

import warnings
from dataclasses import dataclass

import numpy as np

from ..potentials._spline_kernels import bspline_force, bspline_value, grid_force, grid_value
from ..potentials.bounded import BoundedPotential
from ..potentials.compiled import compiled_functions
from ._asked_order import asked_columns, in_asked_order, sorted_times
from ._curve_fixed import curve_rows_fixed
from ._kernels import grid_step, grid_steps, level_gap, rows_fixed, trajectory_fixed
from ._row_doubling import double_one_row
from ._rowwise import rowwise
from .level_grid import DEEP_GAPS, level_grid
from .periodic import DIRECT_HORIZON, HorizonPlan, PeriodError, phase_error, plan_horizon
from .schemes import MAX_STEPS, step_method
from .start_level import start_levels

__all__ = ["RowSolution", "RowSource", "row_source", "solve_rows"]

#: The largest ``max_substeps`` a single row's doubling takes in one compiled call
#: (:func:`~._row_doubling.double_one_row`, whose history has room for its levels);
#: beyond it, and for several rows, the doubling runs level by level in Python.
ONE_ROW_CAP = 2**40


@dataclass
class RowSource:
    """A potential per row as the kernels take it (final).

    Attributes:
        force, value: ``force(par, x) -> -V'(x)`` and ``value(par, x) -> V(x)``, compiled
            (numba) when ``compiled``, else plain Python.
        params: (N, P) float64, row i's parameters (one dummy row for a formula).
        compiled: whether the parallel kernels can run.
        smooth: whether V is C² (see :func:`solve_rows`).
        curve: the rows are B-spline curves; RK4 then runs in the curve parameter
            (:mod:`._curve_fixed`: no inversion of q(λ) per force).
        guarded: the force is held at its end value past ``OUTSIDE_MARGIN`` (sensor
            splines, B-spline curves): V has a kink there.
    """

    force: object
    value: object
    params: np.ndarray
    compiled: bool
    smooth: bool = True
    curve: bool = False
    guarded: bool = False

    def subset(self, rows):
        """The rows ``rows`` as a source of their own (a formula's stays as it is)."""
        if self.params.shape[0] == 1:
            return self
        return RowSource(self.force, self.value, self.params[rows], self.compiled,
                         self.smooth, self.curve, self.guarded)

    def _at(self, fn, x, rows):
        x = np.asarray(x, dtype=np.float64)
        params = self.params if rows is None else self.params[rows]
        flat = x.reshape(x.shape[0], -1)
        out = np.empty(flat.shape)
        if self.compiled and params.shape[0] in (1, flat.shape[0]):
            rowwise(fn, params, np.ascontiguousarray(flat), out)
        else:
            for i in range(flat.shape[0]):
                for j in range(flat.shape[1]):
                    out[i, j] = fn(params[min(i, len(params) - 1)], flat[i, j])
        return out.reshape(x.shape)

    def values_at(self, x, rows=None):
        """V of row i at x[i] (x: (N,) or (N, M); ``rows`` picks rows of params)."""
        return self._at(self.value, x, rows)

    def forces_at(self, x, rows=None):
        """-V' of row i at x[i], like :meth:`values_at`."""
        return self._at(self.force, x, rows)


def row_source(pot, information):
    """A :class:`RowSource` for what :func:`~nh_operators.potentials.as_potential` returns,
    for a batched :class:`BoundedPotential`, or for sensor values (N, 100).

    Example:
        >>> src = row_source("sho", "exact V")  # compiled from its second solve on
        >>> round(src.value(src.params[0], 0.25), 12)
        0.5
    """
    from .fixed_step import sensor_spline_params

    if isinstance(pot, str):
        from ..potentials.coerce import as_potential

        pot, information = as_potential(pot)
    if information == "sensors":
        params = sensor_spline_params(np.atleast_2d(np.asarray(pot, dtype=np.float64)))
        return RowSource(grid_force, grid_value, params, True, guarded=True)
    if isinstance(pot, BoundedPotential):
        return RowSource(bspline_force, bspline_value, pot.params, True, curve=True,
                         guarded=True)
    if isinstance(pot, np.ndarray):
        raise ValueError(f"an array of sensor values needs information 'sensors', got "
                         f"{information!r}")
    smooth = bool(getattr(pot, "smooth", True))
    fns = compiled_functions(pot, after=1)  # compiled from its second solve on
    if fns is not None:
        return RowSource(fns[1], fns[0], np.zeros((1, 1)), True, smooth)

    def force(_par, x):
        return -float(pot.dV(x))

    def value(_par, x):
        return float(pot.V(x))

    return RowSource(force, value, np.zeros((1, 1)), False, smooth)


def _grids(ts, substeps, interval):
    t_max = ts[:, -1]
    steps = t_max * substeps / interval - 1e-9
    if np.any(steps > MAX_STEPS):
        i = int(np.argmax(steps))
        raise ValueError(f"t = {t_max[i]:g} needs {steps[i]:.3g} fixed steps at {substeps} "
                         f"substep(s), more than {MAX_STEPS:g}; without a usable period "
                         "the orbit is integrated directly only up to t = "
                         f"{DIRECT_HORIZON:g}")
    nsteps = np.where(t_max > 0, np.ceil(steps), 0).astype(np.int64)
    hs = np.where(nsteps > 0, t_max / np.maximum(nsteps, 1), 1.0)
    return hs, nsteps


def _one_grid(ts, substeps, interval):
    """:func:`_grids` of one row of sorted times ``ts`` (M,), in Python floats: the same
    IEEE arithmetic, without a dozen array operations per level of a single solve."""
    t_max = float(ts[-1])
    steps = grid_steps(t_max, substeps, interval)
    if steps > MAX_STEPS:
        _grids(ts[None], substeps, np.array([interval]))  # raises its message
    return grid_step(t_max, steps)


def _level(src, rows, work, interval, q0s, p0s, substeps, method, shared=False):
    """Rows ``rows`` at ``substeps``; ``shared``: every row has work[0]'s times and
    interval[0] (one grid for the lockstep kernel, no rows to compare)."""
    rk4, weights = step_method(method)
    if shared:
        work = work[0]
        hs, nsteps = _one_grid(work, substeps, float(interval[0]))
    else:
        hs, nsteps = _grids(work, substeps, interval)
    oq = np.empty((rows.size, work.shape[-1]))
    op = np.empty_like(oq)
    if src.curve and rk4:
        curve_rows_fixed(src.params, rows, work, hs, nsteps, oq, op, q0s, p0s)
    elif src.compiled:
        rows_fixed(src.force, src.params, rows, work, hs, nsteps, rk4, weights,
                   oq, op, q0s, p0s)
    else:
        for k, i in enumerate(rows):
            # shared: one grid (Python scalars) for every row; else row i's (arrays)
            row = ((work[i], hs[i], nsteps[i])
                   if isinstance(hs, np.ndarray) and isinstance(nsteps, np.ndarray)
                   else (work, hs, nsteps))
            trajectory_fixed.py_func(src.force, src.params[0], *row, rk4,
                                     weights, oq[k], op[k], q0s[i], p0s[i])
    return oq, op


@dataclass(frozen=True)
class RowSolution:
    """What :func:`solve_rows` returns (final).

    Attributes:
        q, p: (N, M) the states at the asked times, in the asked order.
        substeps: (N,) int64, the substeps per output interval of the accepted level.
        estimate: (N,) the estimated L_tot, the phase part included.
        period: (N,) the period T of each row answered from one period, nan elsewhere.
        phase: (N,) the phase part of ``estimate``.
        history: for a solve of one row, the (substeps, estimate) of every level; empty
            for more rows.
    """

    q: np.ndarray
    p: np.ndarray
    substeps: np.ndarray
    estimate: np.ndarray
    period: np.ndarray
    phase: np.ndarray
    history: list[tuple[int, float]]


def solve_rows(src, t, q0s, p0s, tols, method="rk4", max_substeps=4096,
               batched=False) -> RowSolution:
    """Solve every row to its tolerance by doubling the substeps (see :mod:`.classical_solve`).

    Args:
        src: a :class:`RowSource` with N rows.
        t: (M,) times shared by all rows, or (N, M) per row; ≥ 0.
        q0s, p0s: (N,) starting states (already checked).
        tols: (N,) target L_tot per row.
        method: a key of :data:`~nh_operators.METHODS`.
        max_substeps: give up (with a warning) beyond this.
        batched: name rows in messages.

    Returns:
        :class:`RowSolution`.

    Raises:
        ValueError: a time beyond float64's resolution, or too many steps.
        PeriodError: see :mod:`.periodic` (a :class:`~.row_error.RowError`: ``row`` names
            the row when ``batched``).
    """
    t = np.asarray(t, dtype=np.float64)
    asked_order, ts = sorted_times(t, q0s.size)
    plan = plan_horizon(src, ts, q0s, p0s, tols, batched)
    grid = level_grid(src, plan, ts, t.ndim == 1, method, *start_levels(src, tols, q0s, p0s))
    solve_tol = (np.sqrt(tols) - np.sqrt(plan.phase)) ** 2
    levels = _doubling(src, grid, q0s, p0s, solve_tol, tols, max_substeps, batched)
    _check_return(plan, grid.with_t, levels, q0s, p0s, tols, batched)
    qa, pa = asked_columns(levels.q, levels.p, plan.column, ts.shape[1])
    phase = phase_error(src, plan, qa, pa, tols, batched)
    q_final, p_final = in_asked_order(qa, pa, asked_order, t.ndim)
    est = (np.sqrt(levels.estimate) + np.sqrt(phase)) ** 2
    return RowSolution(q_final, p_final, levels.substeps, est, plan.period, phase,
                       levels.history)


@dataclass(frozen=True)
class _Levels:
    """What the doubling accepted per row (final): q, p (N, W) at the working times,
    substeps and estimate (N,), and ``history`` (one row: (substeps, estimate) per
    level)."""

    q: np.ndarray
    p: np.ndarray
    substeps: np.ndarray
    estimate: np.ndarray
    history: list[tuple[int, float]]


def _doubling(src, grid, q0s, p0s, solve_tol, tols, max_substeps, batched):
    """Double the substeps until each row's estimate meets ``solve_tol``; a row leaves as
    soon as its own does (or every row at ``max_substeps``, with a warning)."""
    n = q0s.size
    if n == 1 and grid.shared and src.compiled and not src.curve \
            and max_substeps <= ONE_ROW_CAP:
        return _one_row(src, grid, q0s, p0s, solve_tol, tols, max_substeps, batched)
    rows = np.arange(n)
    q_out = p_out = np.empty((0, 0))  # set at the first level a row leaves
    sub_out = np.zeros(n, dtype=np.int64)
    est_out = np.zeros(n)
    q, p = _level(src, rows, grid.work, grid.interval, q0s, p0s, 1, grid.method, grid.shared)
    # the last gaps before this level's, newest first (rows grid.deep count them all)
    back = np.full((n, DEEP_GAPS - 1), np.inf)
    substeps = 1
    history: list[tuple[int, float]] = []
    # a Python force steps in Python, and so does its gap: a first solve of a formula
    # then starts no compiler (numba's first compiled call costs about 0.3 s)
    gap = level_gap if src.compiled else level_gap.py_func
    while rows.size:
        q2, p2 = _level(src, rows, grid.work, grid.interval, q0s, p0s, 2 * substeps,
                        grid.method, grid.shared)
        raw = gap(q, p, q2, p2, grid.weight if grid.weight.shape[0] == 1 else
                        grid.weight[rows])
        substeps *= 2
        # the gap to the previous level, and the one before it shrunk at the method's
        # rate: a coarse pair that agreed by chance does not hide the error (the first
        # gap alone is never evidence)
        estimate = np.maximum(raw, back[rows, 0] / grid.rate[rows])
        estimate = np.where(grid.deep[rows], np.maximum(estimate, back[rows].max(1)),
                            estimate) * grid.safety[rows]
        if n == 1:
            history.append((int(substeps * grid.first[0]), float(estimate[0])))
        done = estimate <= solve_tol[rows]
        capped = 2 * substeps * grid.first[rows] > max_substeps  # per row: own start
        if np.any(capped & ~done):
            short = capped & ~done
            _warn_unreached(tols, rows[short], estimate[short], max_substeps, batched)
        done |= capped
        back[rows, 1:] = back[rows, :-1]
        back[rows, 0] = raw
        if not done.any():  # no row leaves: no copies
            q, p = q2, p2
            continue
        finished = rows[done]
        if rows.size == n:  # the first level any row leaves: it is the output buffer,
            q_out, p_out = q2, p2  # the rows that stay are overwritten when they leave
        else:
            q_out[finished], p_out[finished] = q2[done], p2[done]
        sub_out[finished], est_out[finished] = substeps * grid.first[finished], estimate[done]
        keep = ~done
        rows, q, p = rows[keep], q2[keep], p2[keep]
    return _Levels(q_out, p_out, sub_out, est_out, history)


def _one_row(src, grid, q0s, p0s, solve_tol, tols, max_substeps, batched):
    """:func:`_doubling` of a single row on its shared grid, in one compiled call
    (:func:`~._row_doubling.double_one_row`: the same levels, bit for bit)."""
    rk4, weights = step_method(grid.method)
    work, interval = grid.work[0], float(grid.interval[0])
    out = double_one_row(src.force, src.params[0], work, interval, float(grid.first[0]),
                         float(q0s[0]), float(p0s[0]), float(solve_tol[0]),
                         float(grid.rate[0]), float(grid.safety[0]), bool(grid.deep[0]),
                         max_substeps, grid.weight[0], rk4, weights, DEEP_GAPS,
                         lambda substeps: _one_grid(work, substeps, interval))
    if out.short:
        _warn_unreached(tols, np.zeros(1, dtype=np.int64), np.array([out.estimate]),
                        max_substeps, batched, depth=1)
    return _Levels(out.q[None], out.p[None], np.array([out.substeps], dtype=np.int64),
                   np.array([out.estimate]), out.history)


def _warn_unreached(tols, bad, estimate, max_substeps, batched, depth=0):
    """Warn that rows ``bad`` (with their ``estimate``) miss their tolerance at the cap
    (``depth``: frames between this helper and :func:`_doubling`)."""
    # stacklevel: the frame three above solve_rows (past this helper and _doubling)
    warnings.warn(f"tolerance {tols[bad[0]]:g} not reached within {max_substeps} "
                  f"substeps (estimate {estimate.max():.3g}"
                  + (f", {bad.size} rows" if batched else "")
                  + "); returning the finest solution", RuntimeWarning,
                  stacklevel=6 + depth)


def _check_return(plan: HorizonPlan, with_t, levels, q0s, p0s, tols, batched):
    """Rows answered from one period must return to their start at T (their working
    column m); raise a :class:`PeriodError` for the first that misses by more than
    10 tol (V has a feature the turning-point search stepped over)."""
    column = plan.column
    if column is None:  # no row answered from a period (those have a column)
        return
    checked = np.flatnonzero(with_t)
    if not checked.size:
        return
    m = column.shape[1] - 1
    pos = column[checked, m]
    miss = 0.5 * ((levels.q[checked, pos] - q0s[checked]) ** 2
                  + (levels.p[checked, pos] - p0s[checked]) ** 2)
    bad = np.flatnonzero(miss > 10 * tols[checked])
    if bad.size:
        i = checked[bad[0]]
        raise PeriodError(f"the orbit does not return "
                          f"to its starting state after the period T = "
                          f"{plan.period[i]:.10g} found by quadrature (squared miss "
                          f"{miss[bad[0]]:.2g}): V has a feature the turning-point search "
                          "stepped over", row=int(i) if batched else None)
