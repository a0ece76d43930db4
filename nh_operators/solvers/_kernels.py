"""Compiled (numba) solvers: fixed-step and adaptive trajectories.

The trajectory kernels take a force function ``force(params, x) -> -V'(x)`` (see
:mod:`nh_operators.potentials._spline_kernels`) as an argument. They are inlined into
one-row kernels that call the force by the global name ``FORCE``, which the parallel batch
kernels call in turn: all compiled once per force
(:func:`~nh_operators.potentials._spline_kernels.specialised`) and cached on disk.
The adaptive truth in the curve parameter lives in :mod:`._curve_kernels`. The same
Python source also runs uncompiled (``trajectory_fixed.py_func``) with a plain
Python force, which is how arbitrary user callables are integrated without a second copy
of the steppers. The sensors' spline coefficients come from the one sensor-spline helper
(:func:`nh_operators._sensors.notaknot_params`, re-exported here for the solvers).
"""

import math

import numba
import numpy as np
from numba.extending import register_jitable

from .._sensors import notaknot_params  # noqa: F401 (the solvers' spline kernel)
from ..potentials._spline_kernels import FORCE, JIT, JIT_FN_ARG, specialised

# -------------------------------------------------------------- fixed-step solvers


@register_jitable
def hermite(theta, h, y0, d0, y1, d1):
    """The cubic Hermite interpolant at ``theta`` ∈ [0, 1] of a step of size ``h`` from
    (value y0, derivative d0) to (y1, d1).

    Compiled into the kernels that call it, plain Python when called from Python (the
    uncompiled ``trajectory_fixed.py_func`` of a first solve then starts no compiler)."""
    t2 = theta * theta
    t3 = t2 * theta
    return ((2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + theta) * h * d0
            + (-2 * t3 + 3 * t2) * y1 + (t3 - t2) * h * d1)


@register_jitable
def grid_steps(t_max, substeps, interval):
    """The (fractional) steps of a grid of ``substeps`` per ``interval`` up to ``t_max``;
    more than :data:`~.schemes.MAX_STEPS` is refused by the caller. Plain Python from
    Python (:func:`~.rows._one_grid`), compiled into the kernels that call it."""
    return t_max * substeps / interval - 1e-9


@register_jitable
def grid_step(t_max, steps):
    """(h, nsteps) of the grid of :func:`grid_steps` ``steps`` up to ``t_max``."""
    nsteps = math.ceil(steps) if t_max > 0 else 0
    return (t_max / nsteps if nsteps > 0 else 1.0), nsteps


@numba.njit(**JIT_FN_ARG)
def trajectory_fixed(force, par, tq, h, nsteps, rk4, weights, oq, op, q_start, p_start):
    """One trajectory from (q_start, p_start) with ``nsteps`` steps of size ``h``.

    ``tq`` holds sorted query times in [0, nsteps h]; results are cubic Hermite
    interpolants with the exact derivatives (dq/dt = p, dp/dt = force) at the ends of
    the step that brackets each query. ``rk4`` selects classical RK4; otherwise the
    step is the composition of Störmer–Verlet (kick-drift-kick) steps of size
    ``h * weights[i]``.
    """
    m = tq.shape[0]
    q = q_start
    p = p_start
    f = force(par, q)
    k = 0
    while k < m and tq[k] <= 0.0:
        oq[k] = q_start
        op[k] = p_start
        k += 1
    for n in range(nsteps):
        q0 = q
        p0 = p
        f0 = f
        if rk4:
            h2 = 0.5 * h
            f2 = force(par, q + h2 * p)
            p2 = p + h2 * f
            f3 = force(par, q + h2 * p2)
            p3 = p + h2 * f2
            f4 = force(par, q + h * p3)
            p4 = p + h * f3
            q = q + h / 6.0 * (p + 2.0 * p2 + 2.0 * p3 + p4)
            p = p + h / 6.0 * (f + 2.0 * f2 + 2.0 * f3 + f4)
            f = force(par, q)
        else:
            for w in weights:
                p += 0.5 * h * w * f
                q += h * w * p
                f = force(par, q)
                p += 0.5 * h * w * f
        t0 = n * h
        t1 = (n + 1) * h
        last = n == nsteps - 1
        while k < m and (last or tq[k] <= t1):
            theta = (tq[k] - t0) / h
            oq[k] = hermite(theta, h, q0, p0, q, p)
            op[k] = hermite(theta, h, p0, f0, p, f)
            k += 1


#: Trajectories a kernel advances in lockstep. One trajectory is a chain of dependent
#: force evaluations (each waits for the last); LANES independent chains let the CPU
#: overlap them. Each lane does exactly the arithmetic of :func:`trajectory_fixed`, so
#: the results are bit for bit the same.
LANES = 4


@numba.njit(**JIT_FN_ARG)
def _lanes_fixed(force, pars, rows, lo, tq, h, nsteps, rk4, weights, oq, op, q0s, p0s):
    """Rows ``rows[lo:lo + LANES]`` (outputs ``oq[lo + l]``), which share the sorted
    times ``tq`` and the step grid (``h``, ``nsteps``), advanced side by side."""
    q = np.empty(LANES)
    p = np.empty(LANES)
    f = np.empty(LANES)
    qa = np.empty(LANES)
    pa = np.empty(LANES)
    fa = np.empty(LANES)
    f2 = np.empty(LANES)
    f3 = np.empty(LANES)
    f4 = np.empty(LANES)
    p2 = np.empty(LANES)
    p3 = np.empty(LANES)
    p4 = np.empty(LANES)
    for la in range(LANES):
        i = rows[lo + la]
        q[la] = q0s[i]
        p[la] = p0s[i]
        f[la] = force(pars[i], q[la])
    m = tq.shape[0]
    k = 0
    while k < m and tq[k] <= 0.0:
        for la in range(LANES):
            oq[lo + la, k] = q0s[rows[lo + la]]
            op[lo + la, k] = p0s[rows[lo + la]]
        k += 1
    h2 = 0.5 * h
    for n in range(nsteps):
        for la in range(LANES):
            qa[la] = q[la]
            pa[la] = p[la]
            fa[la] = f[la]
        if rk4:
            for la in range(LANES):
                f2[la] = force(pars[rows[lo + la]], q[la] + h2 * p[la])
                p2[la] = p[la] + h2 * f[la]
            for la in range(LANES):
                f3[la] = force(pars[rows[lo + la]], q[la] + h2 * p2[la])
                p3[la] = p[la] + h2 * f2[la]
            for la in range(LANES):
                f4[la] = force(pars[rows[lo + la]], q[la] + h * p3[la])
                p4[la] = p[la] + h * f3[la]
            for la in range(LANES):
                q[la] = q[la] + h / 6.0 * (p[la] + 2.0 * p2[la] + 2.0 * p3[la] + p4[la])
                p[la] = p[la] + h / 6.0 * (f[la] + 2.0 * f2[la] + 2.0 * f3[la] + f4[la])
                f[la] = force(pars[rows[lo + la]], q[la])
        else:
            for w in weights:
                for la in range(LANES):
                    p[la] += 0.5 * h * w * f[la]
                    q[la] += h * w * p[la]
                    f[la] = force(pars[rows[lo + la]], q[la])
                    p[la] += 0.5 * h * w * f[la]
        t0 = n * h
        t1 = (n + 1) * h
        last = n == nsteps - 1
        while k < m and (last or tq[k] <= t1):
            theta = (tq[k] - t0) / h
            for la in range(LANES):
                oq[lo + la, k] = hermite(theta, h, qa[la], pa[la], q[la], p[la])
                op[lo + la, k] = hermite(theta, h, pa[la], fa[la], p[la], f[la])
            k += 1


# Templates, compiled per force by :func:`_for_force`: one row (or LANES rows) with the
# stepper inlined, then the parallel loops over rows, which call those copies by name.


def _trajectory_row(par, tq, h, nsteps, rk4, weights, oq, op, q_start, p_start):
    trajectory_fixed(FORCE, par, tq, h, nsteps, rk4, weights, oq, op, q_start, p_start)


def _lanes_row(pars, rows, lo, tq, h, nsteps, rk4, weights, oq, op, q0s, p0s):
    _lanes_fixed(FORCE, pars, rows, lo, tq, h, nsteps, rk4, weights, oq, op, q0s, p0s)


def _shared_grid(pars, rows, tq, h, nsteps, rk4, weights, oq, op, q0s, p0s):
    """Rows ``rows`` on one time grid: LANES at a time, the remainder one by one."""
    blocks = rows.shape[0] // LANES
    for b in numba.prange(blocks):
        _lanes_row(pars, rows, b * LANES, tq, h, nsteps, rk4, weights, oq, op, q0s, p0s)
    for k in numba.prange(blocks * LANES, rows.shape[0]):
        i = rows[k]
        _trajectory_row(pars[i], tq, h, nsteps, rk4, weights, oq[k], op[k], q0s[i], p0s[i])


def _own_grids(pars, rows, tq, hs, nsteps, rk4, weights, oq, op, q0s, p0s):
    """Rows ``rows``, each on its own grid."""
    for k in numba.prange(rows.shape[0]):
        i = rows[k]
        _trajectory_row(pars[i], tq[i], hs[i], nsteps[i], rk4, weights, oq[k], op[k], q0s[i],
                        p0s[i])


_FOR_FORCE = {}


def _for_force(template, force):
    """The compiled ``template`` (:func:`_shared_grid`, :func:`_own_grids`) of ``force``."""
    kernel = _FOR_FORCE.get((template, force))
    if kernel is None:
        rows = {"_trajectory_row": specialised(_trajectory_row, {"FORCE": force})}
        if template is _shared_grid:
            rows["_lanes_row"] = specialised(_lanes_row, {"FORCE": force})
        kernel = _FOR_FORCE[template, force] = specialised(template, rows, parallel=True)
    return kernel


def batch_fixed(force, pars, tq, h, nsteps, rk4, weights, oq, op, q0s, p0s):
    """Every row of ``pars`` on the shared sorted times ``tq`` and step grid."""
    rows = np.arange(pars.shape[0])
    _for_force(_shared_grid, force)(pars, rows, tq, h, nsteps, rk4, weights, oq, op, q0s, p0s)


def rows_fixed(force, pars, rows, tq, hs, nsteps, rk4, weights, oq, op, q0s, p0s):
    """Row ``rows[k]`` of every per-row array, with its own sorted times and step grid
    (in lockstep when the rows share them), into ``oq[k]``, ``op[k]``.

    ``tq`` (M,) with scalar ``hs`` and ``nsteps``: one grid shared by every row, taken
    as it is; per-row ``tq`` (N, M), ``hs``, ``nsteps`` are compared first."""
    if tq.ndim == 1:
        _for_force(_shared_grid, force)(pars, rows, np.ascontiguousarray(tq), hs, nsteps,
                                        rk4, weights, oq, op, q0s, p0s)
        return
    first = rows[0] if rows.size else 0
    if rows.size and np.all(hs[rows] == hs[first]) and np.all(nsteps[rows] == nsteps[first]) \
            and np.all(tq[rows] == tq[first]):
        _for_force(_shared_grid, force)(pars, rows, np.ascontiguousarray(tq[first]),
                                        hs[first], nsteps[first], rk4, weights, oq, op, q0s,
                                        p0s)
    else:
        _for_force(_own_grids, force)(pars, rows, tq, hs, nsteps, rk4, weights, oq, op, q0s,
                                      p0s)


@numba.njit(parallel=True, **JIT)
def level_gap(q, p, q2, p2, w):
    """½ Σ_j w_j ((q2 − q)² + (p2 − p)²) of every row (K,): the gap of two levels.

    ``w`` is (K, M), or (1, M) shared by all rows."""
    out = np.empty(q.shape[0])
    own = w.shape[0] > 1
    for i in numba.prange(q.shape[0]):
        out[i] = row_gap(q[i], p[i], q2[i], p2[i], w[i] if own else w[0])
    return out


@register_jitable
def row_gap(q, p, q2, p2, w):
    """½ Σ_j w_j ((q2 − q)² + (p2 − p)²) of one row (M,) each: :func:`level_gap`'s."""
    s = 0.0
    for j in range(q.shape[0]):
        # products, not ** 2: plain Python (``level_gap.py_func``) then computes the
        # same numbers as the compiled kernel
        dq, dp = q2[j] - q[j], p2[j] - p[j]
        s += w[j] * (dq * dq + dp * dp)
    return 0.5 * s
