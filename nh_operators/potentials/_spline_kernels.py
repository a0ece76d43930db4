"""Compiled (numba) piecewise-cubic potentials: clamped B-spline curves and cubics on a q-grid.

Every force function has the signature ``force(params, x) -> -V'(x)`` with ``params``
a 1-D float64 row; the solvers' kernels (:mod:`nh_operators.solvers._kernels`) take such
a function as an argument, and numba compiles one specialisation per force.
"""

import math

import numba

from .bspline import Q_OFFSET, V_OFFSET

_JIT = dict(nogil=True, cache=True)
# Kernels that take another compiled function as an argument are not cached: numba keys
# their cache entries by the dispatcher object of this process, so entries never match
# again, the index grows with every process, and saving it eventually fails with
# "ReferenceError: underlying object has vanished" (numba 0.6x). They compile in ~1 s.
_JIT_FN_ARG = dict(nogil=True, cache=False)


@numba.njit(**_JIT)
def _cubic(c, o, s):
    return c[o] + s * (c[o + 1] + s * (c[o + 2] + s * c[o + 3]))


@numba.njit(**_JIT)
def _dcubic(c, o, s):
    return c[o + 1] + s * (2.0 * c[o + 2] + s * 3.0 * c[o + 3])


@numba.njit(**_JIT)
def _d2cubic(c, o, s):
    return 2.0 * c[o + 2] + 6.0 * s * c[o + 3]


# ---------------------------------------------------------------- B-spline potentials


@numba.njit(**_JIT)
def bspline_locate(par, x):
    """Return (piece offset, s) with q(s) = x on that piece, by safeguarded Newton."""
    pieces = int(par[0])
    j = 0
    for jj in range(1, pieces):
        if par[Q_OFFSET + 4 * jj] <= x:
            j = jj
        else:
            break
    oq = Q_OFFSET + 4 * j
    q_lo = par[oq]
    q_hi = _cubic(par, oq, 1.0)
    if x < q_lo:  # left of the curve: extrapolate the first piece
        lo, hi = -1.0, 0.0
    elif x > q_hi:  # right of the curve: extrapolate the last piece
        lo, hi = 1.0, 2.0
    else:
        lo, hi = 0.0, 1.0
    s = (x - q_lo) / (q_hi - q_lo)
    s = min(max(s, lo), hi)
    for _ in range(100):
        g = _cubic(par, oq, s) - x
        if g == 0.0:
            break
        if g > 0.0:
            hi = s
        else:
            lo = s
        d = _dcubic(par, oq, s)
        step = g / d if d > 0.0 else 2.0 * (hi - lo)
        s_new = s - step
        if not (lo <= s_new <= hi):
            s_new = 0.5 * (lo + hi)
        if abs(s_new - s) <= 1e-16 * (1.0 + abs(s)):
            s = s_new
            break
        s = s_new
    return j, s


@numba.njit(**_JIT)
def bspline_value(par, x):
    j, s = bspline_locate(par, x)
    return _cubic(par, V_OFFSET + 4 * j, s)


#: Within this distance outside [0, 1] forces follow the end pieces (so a stage that
#: overshoots a turning point sees the smooth continuation); farther out they are held
#: at their end values, so a coarse step that overshoots a steep wall is pushed back
#: instead of following an extrapolated cubic away.
OUTSIDE_MARGIN = 0.05


@numba.njit(**_JIT)
def _guard(x):
    if x < -OUTSIDE_MARGIN:
        return 0.0
    if x > 1.0 + OUTSIDE_MARGIN:
        return 1.0
    return x


@numba.njit(**_JIT)
def bspline_force(par, x):
    j, s = bspline_locate(par, _guard(x))
    return -_dcubic(par, V_OFFSET + 4 * j, s) / _dcubic(par, Q_OFFSET + 4 * j, s)


@numba.njit(**_JIT)
def bspline_curvature(par, x):
    """d²V/dq² from the curve: (V'' q' - V' q'') / q'³ in the curve parameter."""
    j, s = bspline_locate(par, x)
    oq = Q_OFFSET + 4 * j
    ov = V_OFFSET + 4 * j
    dq = _dcubic(par, oq, s)
    return (_d2cubic(par, ov, s) * dq - _dcubic(par, ov, s) * _d2cubic(par, oq, s)) / dq**3


# ------------------------------------------------- piecewise cubics on a uniform q-grid


@numba.njit(**_JIT)
def _grid_piece(par, x):
    n = par.shape[0] // 4
    u = x * n
    j = min(max(int(math.floor(u)), 0), n - 1)
    return 4 * j, u - j, n


@numba.njit(**_JIT)
def grid_value(par, x):
    o, s, _ = _grid_piece(par, x)
    return _cubic(par, o, s)


@numba.njit(**_JIT)
def grid_force(par, x):
    o, s, n = _grid_piece(par, _guard(x))
    return -n * _dcubic(par, o, s)


# ------------------------------------------------------------- vectorised evaluation


@numba.njit(parallel=True, **_JIT_FN_ARG)
def evaluate(fn, pars, xs, out):
    """out[i, k] = fn(pars[i], xs[k]) for every potential i and point k."""
    for i in numba.prange(pars.shape[0]):
        for k in range(xs.shape[0]):
            out[i, k] = fn(pars[i], xs[k])
