"""Compiled (numba) fixed-step RK4 on a B-spline curve, in the curve parameter λ.

A generator potential is a curve (q(λ), V(λ)) of cubic pieces. Its force as a function
of q, -V'(q), needs q(λ) = x inverted at every evaluation (a safeguarded Newton of a few
cubic evaluations, :func:`~nh_operators.potentials._spline_kernels.bspline_locate`).
Written in λ, Hamilton's equations need no inversion:

    dλ/dt = p / q_λ(λ),    dp/dt = -V_λ(λ) / q_λ(λ),

two cubic derivatives per evaluation, about what the sensors' spline costs. Classical
RK4 on (λ, p) has the same order as RK4 on (q, p) (a smooth change of variables while
q_λ > 0, which a bounded potential's curve has), with other error constants: the
substep doubling of :func:`~nh_operators.solvers.rows.solve_rows` measures its error the
same way. Query times between step ends come from cubic Hermite interpolation of λ and
p with their exact derivatives; q is then q(λ) on the curve, so every answer lies on it.

A stage that overshoots a wall sees the end piece's continuation within
:data:`LAMBDA_MARGIN` pieces of the ends; farther out λ is held there (as the force in q
is held beyond :data:`~nh_operators.potentials._spline_kernels.OUTSIDE_MARGIN`).
"""

import math

import numba
import numpy as np

from ..potentials._spline_kernels import JIT, cubic, dcubic
from ..potentials.bspline import Q_OFFSET, V_OFFSET
from ._curve_kernels import curve_parameter
from ._kernels import hermite

__all__ = ["curve_rows_fixed"]

#: How far past λ = 0 and λ = 1, in pieces, a stage still follows the end piece.
LAMBDA_MARGIN = 0.25


@numba.njit(**JIT)
def _rates(par, lam):
    """(dλ/dt per unit p, dp/dt) at λ: 1 / q_λ and -V_λ / q_λ."""
    pieces = int(par[0])
    u = min(max(lam * pieces, -LAMBDA_MARGIN), pieces + LAMBDA_MARGIN)
    j = min(max(int(math.floor(u)), 0), pieces - 1)
    s = u - j
    r = 1.0 / dcubic(par, Q_OFFSET + 4 * j, s)
    return r / pieces, -dcubic(par, V_OFFSET + 4 * j, s) * r


@numba.njit(**JIT)
def _q_at(par, lam):
    pieces = int(par[0])
    u = min(max(lam * pieces, 0.0), float(pieces))
    j = min(int(math.floor(u)), pieces - 1)
    return cubic(par, Q_OFFSET + 4 * j, u - j)


@numba.njit(**JIT)
def _curve_row(par, tq, h, nsteps, oq, op, q_start, p_start):
    """One trajectory from (q_start, p_start): ``nsteps`` RK4 steps of size ``h`` in
    (λ, p); ``tq`` sorted in [0, nsteps h]; results into ``oq``, ``op``."""
    m = tq.shape[0]
    lam = 0.0 if q_start <= 0.0 else curve_parameter(par, q_start)
    p = p_start
    g, f = _rates(par, lam)
    k = 0
    while k < m and tq[k] <= 0.0:
        oq[k] = q_start
        op[k] = p_start
        k += 1
    h2 = 0.5 * h
    for n in range(nsteps):
        lam0 = lam
        p0 = p
        dl0 = p * g
        f0 = f
        p2 = p + h2 * f
        g2, f2 = _rates(par, lam + h2 * dl0)
        d2 = p2 * g2
        p3 = p + h2 * f2
        g3, f3 = _rates(par, lam + h2 * d2)
        d3 = p3 * g3
        p4 = p + h * f3
        g4, f4 = _rates(par, lam + h * d3)
        d4 = p4 * g4
        lam = lam + h / 6.0 * (dl0 + 2.0 * d2 + 2.0 * d3 + d4)
        p = p + h / 6.0 * (f + 2.0 * f2 + 2.0 * f3 + f4)
        g, f = _rates(par, lam)
        t0 = n * h
        t1 = (n + 1) * h
        last = n == nsteps - 1
        while k < m and (last or tq[k] <= t1):
            theta = (tq[k] - t0) / h
            oq[k] = _q_at(par, hermite(theta, h, lam0, dl0, lam, p * g))
            op[k] = hermite(theta, h, p0, f0, p, f)
            k += 1


#: Rows a lockstep kernel advances side by side (independent chains of dependent force
#: evaluations that the CPU overlaps); each lane does exactly :func:`_curve_row`'s
#: arithmetic, so the results are bit for bit the same.
LANES = 4


@numba.njit(**JIT)
def _curve_lanes(pars, rows, lo, tq, h, nsteps, oq, op, q0s, p0s):
    """Rows ``rows[lo:lo + LANES]`` (outputs ``oq[lo + l]``) on one step grid."""
    lam = np.empty(LANES)
    p = np.empty(LANES)
    g = np.empty(LANES)
    f = np.empty(LANES)
    lam0 = np.empty(LANES)
    p0 = np.empty(LANES)
    dl0 = np.empty(LANES)
    f0 = np.empty(LANES)
    p2 = np.empty(LANES)
    p3 = np.empty(LANES)
    p4 = np.empty(LANES)
    d2 = np.empty(LANES)
    d3 = np.empty(LANES)
    d4 = np.empty(LANES)
    f2 = np.empty(LANES)
    f3 = np.empty(LANES)
    f4 = np.empty(LANES)
    for la in range(LANES):
        i = rows[lo + la]
        lam[la] = 0.0 if q0s[i] <= 0.0 else curve_parameter(pars[i], q0s[i])
        p[la] = p0s[i]
        g[la], f[la] = _rates(pars[i], lam[la])
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
            lam0[la] = lam[la]
            p0[la] = p[la]
            dl0[la] = p[la] * g[la]
            f0[la] = f[la]
            p2[la] = p[la] + h2 * f[la]
            g2, f2[la] = _rates(pars[rows[lo + la]], lam[la] + h2 * dl0[la])
            d2[la] = p2[la] * g2
        for la in range(LANES):
            p3[la] = p[la] + h2 * f2[la]
            g3, f3[la] = _rates(pars[rows[lo + la]], lam[la] + h2 * d2[la])
            d3[la] = p3[la] * g3
        for la in range(LANES):
            p4[la] = p[la] + h * f3[la]
            g4, f4[la] = _rates(pars[rows[lo + la]], lam[la] + h * d3[la])
            d4[la] = p4[la] * g4
        for la in range(LANES):
            lam[la] = lam[la] + h / 6.0 * (dl0[la] + 2.0 * d2[la] + 2.0 * d3[la] + d4[la])
            p[la] = p[la] + h / 6.0 * (f[la] + 2.0 * f2[la] + 2.0 * f3[la] + f4[la])
            g[la], f[la] = _rates(pars[rows[lo + la]], lam[la])
        t0 = n * h
        t1 = (n + 1) * h
        last = n == nsteps - 1
        while k < m and (last or tq[k] <= t1):
            theta = (tq[k] - t0) / h
            for la in range(LANES):
                par = pars[rows[lo + la]]
                oq[lo + la, k] = _q_at(par, hermite(theta, h, lam0[la], dl0[la], lam[la],
                                                     p[la] * g[la]))
                op[lo + la, k] = hermite(theta, h, p0[la], f0[la], p[la], f[la])
            k += 1


@numba.njit(parallel=True, **JIT)
def _shared_grid(pars, rows, tq, h, nsteps, oq, op, q0s, p0s):
    blocks = rows.shape[0] // LANES
    for b in numba.prange(blocks):
        _curve_lanes(pars, rows, b * LANES, tq, h, nsteps, oq, op, q0s, p0s)
    for k in numba.prange(blocks * LANES, rows.shape[0]):
        i = rows[k]
        _curve_row(pars[i], tq, h, nsteps, oq[k], op[k], q0s[i], p0s[i])


@numba.njit(parallel=True, **JIT)
def _own_grids(pars, rows, tq, hs, nsteps, oq, op, q0s, p0s):
    for k in numba.prange(rows.shape[0]):
        i = rows[k]
        _curve_row(pars[i], tq[i], hs[i], nsteps[i], oq[k], op[k], q0s[i], p0s[i])


def curve_rows_fixed(pars, rows, tq, hs, nsteps, oq, op, q0s, p0s):
    """RK4 in λ for row ``rows[k]`` of the per-row arrays, into ``oq[k]``, ``op[k]``
    (the arguments of :func:`~nh_operators.solvers._kernels.rows_fixed` without the
    force and the scheme: ``tq`` (M,) with scalar ``hs``, ``nsteps`` for one grid, or
    per row (N, M), (N,), (N,))."""
    if tq.ndim == 1:
        _shared_grid(pars, rows, np.ascontiguousarray(tq), float(hs), int(nsteps), oq, op,
                     q0s, p0s)
    else:
        _own_grids(pars, rows, tq, hs, nsteps, oq, op, q0s, p0s)
