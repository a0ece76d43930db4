"""Compiled (numba) truth on a B-spline curve: adaptive Dormand–Prince 5(4) in the curve
parameter λ, from any point of the curve.

In λ, Hamilton's equations read λ' = p / q_λ(λ), p' = −V_λ(λ) / q_λ(λ): two cubic
derivatives per evaluation. Why λ: the force in q needs q(λ) = x inverted at every
evaluation (a Newton iteration), which at the reference's tolerances (1e-15) would be
most of the cost and add its own rounding.
"""

import math

import numba
import numpy as np

from ..potentials._spline_kernels import JIT, cubic, dcubic
from ..potentials.bspline import Q_OFFSET, V_OFFSET

_C = (0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0)
_A = (
    (),
    (1 / 5,),
    (3 / 40, 9 / 40),
    (44 / 45, -56 / 15, 32 / 9),
    (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
    (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
    (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84),
)
_B5 = np.array(_A[6] + (0.0,))
_B4 = np.array((5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40))
_E = _B5 - _B4
_AM = np.zeros((7, 7))
for _i, _row in enumerate(_A):
    _AM[_i, : len(_row)] = _row


@numba.njit(**JIT)
def _curve_rhs(par, lam, p):
    """Hamilton's equations in the curve parameter: λ' = p / q_λ, p' = -V_λ / q_λ."""
    pieces = int(par[0])
    u = lam * pieces
    j = min(max(int(math.floor(u)), 0), pieces - 1)
    s = u - j
    dq = dcubic(par, Q_OFFSET + 4 * j, s)
    return p / (pieces * dq), -dcubic(par, V_OFFSET + 4 * j, s) / dq


@numba.njit(**JIT)
def _curve_point(par, lam):
    pieces = int(par[0])
    u = lam * pieces
    j = min(max(int(math.floor(u)), 0), pieces - 1)
    s = u - j
    return cubic(par, Q_OFFSET + 4 * j, s), cubic(par, V_OFFSET + 4 * j, s)


@numba.njit(**JIT)
def curve_parameter(par, q):
    """The λ with q(λ) = q on a curve whose q(λ) increases, by bisection to rounding."""
    lo, hi = 0.0, 1.0
    while True:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            return lo if q - _curve_point(par, lo)[0] <= _curve_point(par, hi)[0] - q else hi
        if _curve_point(par, mid)[0] < q:
            lo = mid
        else:
            hi = mid


@numba.njit(**JIT)
def _trajectory_dp5(par, tq, rtol, atol, max_steps, oq, op, ov, lam0, p0):
    """Adaptive DP5(4) solve of one B-spline potential from (λ0, p0), landing exactly on
    each tq.

    Returns the number of accepted steps, or -1 if ``max_steps`` was exhausted.
    """
    kl = np.empty(7)
    kp = np.empty(7)
    lam = lam0
    p = p0
    t = 0.0
    h = 1e-3
    steps = 0
    kl[0], kp[0] = _curve_rhs(par, lam, p)
    for k in range(tq.shape[0]):
        while t < tq[k]:
            if steps >= max_steps:
                return -1
            remaining = tq[k] - t
            hit = h >= remaining
            hs = remaining if hit else h
            for i in range(1, 7):
                sl = lam
                sp = p
                for j in range(i):
                    sl += hs * _AM[i, j] * kl[j]
                    sp += hs * _AM[i, j] * kp[j]
                kl[i], kp[i] = _curve_rhs(par, sl, sp)
            el = 0.0
            ep = 0.0
            for i in range(7):
                el += hs * _E[i] * kl[i]
                ep += hs * _E[i] * kp[i]
            # stage 7 evaluated at the 5th-order solution (FSAL)
            sc_l = atol + rtol * max(abs(lam), abs(sl))
            sc_p = atol + rtol * max(abs(p), abs(sp))
            err = math.sqrt(0.5 * ((el / sc_l) ** 2 + (ep / sc_p) ** 2))
            if err <= 1.0:
                lam = sl
                p = sp
                t = tq[k] if hit else t + hs
                kl[0] = kl[6]
                kp[0] = kp[6]
                steps += 1
                factor = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err**-0.2))
                if not hit:
                    h = hs * factor
            else:
                h = hs * max(0.2, 0.9 * err**-0.2)
        qk, vk = _curve_point(par, lam)
        oq[k] = qk
        op[k] = p
        ov[k] = 0.5 * p * p + vk
    return steps


@numba.njit(parallel=True, **JIT)
def batch_dp5(pars, tq, rtol, atol, max_steps, oq, op, ov, steps, lam0s, p0s):
    """Row i from the curve parameter lam0s[i] with momentum p0s[i]."""
    for i in numba.prange(pars.shape[0]):
        steps[i] = _trajectory_dp5(pars[i], tq, rtol, atol, max_steps, oq[i], op[i], ov[i],
                                   lam0s[i], p0s[i])


@numba.njit(parallel=True, **JIT)
def curve_starts(pars, q0s, lam0s, v0s):
    """The curve parameter λ0 of q0s[i] on row i's curve, and V there."""
    for i in numba.prange(pars.shape[0]):
        lam0s[i] = 0.0 if q0s[i] <= 0.0 else curve_parameter(pars[i], q0s[i])
        v0s[i] = _curve_point(pars[i], lam0s[i])[1]
