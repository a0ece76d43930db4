"""The period of a bounded 1-D orbit: turning points and an adaptive quadrature of dq/|p|.

:func:`orbit_period` is written once as plain Python and compiled with numba for every
potential whose ``value(par, x)`` and ``force(par, x)`` are compiled functions (B-splines,
sensor splines, compiled formulas); a potential only known as a Python callable runs the
same source uncompiled (``orbit_period`` itself), so there is one copy of the algorithm.

The turning points are bracketed on a grid of 1/256 (whose values also bound |V'| by
their differences) and pinned down to adjacent floats by the Illinois variant of regula
falsi, safeguarded by bisection (~10 values a side instead of ~50).

The half period is ∫ dq / sqrt(2 (E − V(q))) between the turning points a < b. With
q = a + (b − a) sin²(θ/2), θ ∈ [0, π], the inverse square roots at both ends cancel
against dq = (b − a)/2 · sin θ dθ and the integrand is smooth wherever V is; a kink of V
(or the slow passage over a barrier) is handled by adaptive Gauss–Kronrod (7, 15)
bisection. The nodes never touch θ = 0 or π, so the rounding of the turning points
(about one ulp) changes T by O(ulp), not by O(sqrt(ulp)). Near a turning point E − V(q)
is small and its rounding (a few ulps of E) is not: a panel is accepted once its
Kronrod–Gauss difference is below that rounding, so the bisection does not chase noise;
the difference still enters the error bound. The quadrature stops at the accuracy the
caller's horizon needs (``rate``), between 1e-14 and 1e-9 relative.
"""

import math

import numba
import numpy as np

from ..potentials._spline_kernels import FN, FORCE, VALUE, JIT, JIT_FN_ARG, specialised

#: Status codes of :func:`orbit_period`.
OK, STATIONARY, NOT_CONVERGED, BARRIER = 0, 1, 2, 3

# Gauss–Kronrod (7, 15) on [-1, 1]: Kronrod nodes, their weights, and the Gauss weights
# of the odd-indexed nodes (which are the 7 Gauss nodes).
_XK = np.array([0.991455371120812639206854697526329, 0.949107912342758524526189684047851,
                0.864864423359769072789712788640926, 0.741531185599394439863864773280788,
                0.586087235467691130294144845693013, 0.405845151377397166906606412076961,
                0.207784955007898467600689403773245, 0.0])
_WK = np.array([0.022935322010529224963732008058970, 0.063092092629978553290700663189204,
                0.104790010322250183839876322541518, 0.140653259715525918745189590510238,
                0.169004726639267902826583426598550, 0.190350578064785409913256402421014,
                0.204432940075298892414161999234649, 0.209482141084727828012999174891714])
_WG = np.array([0.129484966168869693270611432679082, 0.279705391489276667901467771423780,
                0.381830050505118944950369775488975, 0.417959183673469387755102040816327])

_MARCH = 1.0 / 256.0  # grid on which the turning points are bracketed
_MAX_PANELS = 4000
#: The finest relative accuracy of the period asked for (about what float64 resolves).
REL_FINEST = 1e-14
#: The coarsest: a period known to worse than 1e-8 relative is not used (.periodic).
REL_COARSEST = 1e-9
_OUTSIDE = 0.05  # how far past a wall a turning point is looked for
_FLAT = 1e-7  # |V'| at a turning point below this share of max |V'|: a separatrix


@numba.njit(**JIT)
def _at_rest(out, q0):
    """Fill ``out`` for a particle that stays at q0 (no period); returns STATIONARY."""
    out[0] = math.inf
    out[1] = 0.0
    out[2] = q0
    out[3] = q0
    out[4] = 0.0
    out[6] = q0
    return STATIONARY


_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


def orbit_period(value, force, par, q0, p0, rate, out):
    """Period of the orbit through (q0, p0); writes out[0..6] and returns a status.

    rate: the drift of the state per unit time that T's error may cause. An error δT
    moves the state by up to (t/T) δT sqrt(S) at time t, so T is aimed at the relative
    accuracy rate / sqrt(S), between :data:`REL_FINEST` and :data:`REL_COARSEST` (rate 0:
    the finest). A far horizon or a tight tolerance needs a finer T than a near one
    (:func:`.periodic.plan_horizon`).

    out: T, its error bound, a, b, S (a bound on p² + V'² along the orbit), the energy,
    and q where the integrand peaked (a barrier top when the quadrature fails).
    """
    energy = 0.5 * p0 * p0 + value(par, q0)
    out[5] = energy
    smax_p = 0.0
    smax_f = 0.0
    x_in = q0
    fixed_side = 0  # a side whose turning point is q0 itself (released at rest)
    if not (energy - value(par, q0) > 0.0):
        f0 = force(par, q0)
        if f0 == 0.0:
            return _at_rest(out, q0)
        direction = 1.0 if f0 > 0.0 else -1.0
        fixed_side = -1 if f0 > 0.0 else 1
        found = False
        step = _MARCH
        for _ in range(40):
            x = min(max(q0 + direction * step, 0.0), 1.0)
            if energy - value(par, x) > 0.0:
                x_in = x
                found = True
                break
            step *= 0.5
        if not found:
            return _at_rest(out, q0)
    ends = np.empty(2)
    flat = np.full(2, math.inf)  # |V'| at the turning points found inside
    for side in range(2):
        direction = -1.0 if side == 0 else 1.0
        if (side == 0 and fixed_side == -1) or (side == 1 and fixed_side == 1):
            ends[side] = q0
            continue
        x = x_in
        v = value(par, x_in)
        x_back = x_in - direction * _MARCH  # the sample behind: a top between samples
        v_back = value(par, x_back) if -_OUTSIDE < x_back < 1.0 + _OUTSIDE else math.inf
        wall = False
        while True:
            # past a wall only when E exceeds V there (by rounding): the true turning
            # point is then just outside, where the force follows the end pieces
            xn = x + direction * _MARCH
            if (xn < 0.0 or xn > 1.0) and (x > 0.0 and x < 1.0):
                xn = 0.0 if xn < 0.0 else 1.0
            vn = value(par, xn)
            if xn != x:  # V' somewhere in between (mean value): for the bound S
                smax_f = max(smax_f, ((vn - v) / (xn - x)) ** 2)
            if not (energy - vn > 0.0):
                break
            if v >= v_back and v >= vn and xn != x:
                # V peaks between x_back and xn, where the samples stay below E: find the
                # top (golden section) in case it reaches E between them
                # (inline: this source also runs uncompiled, with Python callables)
                ga, gb = min(x_back, xn), max(x_back, xn)
                gc, gd = gb - _GOLDEN * (gb - ga), ga + _GOLDEN * (gb - ga)
                vc, vd = value(par, gc), value(par, gd)
                while gb - ga > 1e-13:  # V is flat at a top: its value right to ~1e-26
                    if vc >= vd:
                        gb, gd, vd = gd, gc, vc
                        gc = gb - _GOLDEN * (gb - ga)
                        vc = value(par, gc)
                    else:
                        ga, gc, vc = gc, gd, vd
                        gd = ga + _GOLDEN * (gb - ga)
                        vd = value(par, gd)
                top, v_top = (gc, vc) if vc >= vd else (gd, vd)
                if not (energy - v_top > 0.0):
                    if direction * (top - x) < 0.0:  # the top lies behind x
                        x, v = x_back, v_back
                    xn, vn = top, v_top
                    break
            smax_p = max(smax_p, 2.0 * (energy - vn))
            if xn <= -_OUTSIDE or xn >= 1.0 + _OUTSIDE:
                wall = True
                break
            x_back, v_back = x, v
            x = xn
            v = vn
        if wall:
            ends[side] = xn
            continue
        # E - V changes sign between x (inside, g > 0) and xn (outside, g <= 0): the
        # Illinois variant of regula falsi, bisecting whenever the bracket does not
        # halve in two steps, down to two adjacent floats
        lo, glo = x, energy - v
        hi, ghi = xn, energy - vn
        kept = 0  # +1: lo kept last step, -1: hi kept
        width = abs(hi - lo)
        for it in range(200):
            mid = 0.5 * (lo + hi)
            if mid == lo or mid == hi:
                break
            bisect = False
            if it % 2 == 0:
                bisect = it > 0 and abs(hi - lo) > 0.5 * width
                width = abs(hi - lo)
            if not bisect and glo - ghi > 0.0:
                sec = lo + glo / (glo - ghi) * (hi - lo)
                if min(lo, hi) < sec < max(lo, hi):
                    mid = sec
            g = energy - value(par, mid)
            if g > 0.0:
                lo, glo = mid, g
                if kept == -1:
                    ghi *= 0.5
                kept = -1
            else:
                hi, ghi = mid, g
                if kept == 1:
                    glo *= 0.5
                kept = 1
        ends[side] = lo
        fe = force(par, lo)
        smax_f = max(smax_f, fe * fe)
        flat[side] = abs(fe)
    a = ends[0]
    b = ends[1]
    fq = force(par, q0)
    out[2] = a
    out[3] = b
    out[4] = max(smax_p, 2.0 * (energy - value(par, q0))) + max(smax_f, fq * fq)
    # an orbit whose kinetic energy is at the rounding level of E: at rest (its motion,
    # of amplitude ~ sqrt(ulp), is below what E - V(q) resolves)
    kinetic = max(energy - value(par, 0.5 * (a + b)), energy - value(par, q0), 0.5 * smax_p)
    if kinetic <= 1e-15 * (1.0 + abs(energy)):
        out[0] = math.inf
        out[1] = 0.0
        out[6] = q0
        return STATIONARY
    # a turning point where V' vanishes is a barrier top reached at zero speed
    for side in range(2):
        if flat[side] < _FLAT * math.sqrt(max(smax_f, fq * fq)):
            out[0] = math.inf
            out[1] = math.inf
            out[6] = ends[side]
            return BARRIER
    rel = REL_FINEST
    if out[4] > 0.0:
        rel = min(max(rate / math.sqrt(out[4]), REL_FINEST), REL_COARSEST)
    slope_a = abs(force(par, a))
    slope_b = abs(force(par, b))
    # adaptive Gauss–Kronrod on θ ∈ [0, π]
    half = 0.5 * (b - a)
    lo_stack = np.empty(_MAX_PANELS)
    hi_stack = np.empty(_MAX_PANELS)
    n_stack = 0
    panels = 8
    for k in range(panels):
        lo_stack[n_stack] = math.pi * k / panels
        hi_stack[n_stack] = math.pi * (k + 1) / panels
        n_stack += 1
    total = 0.0
    error = 0.0
    rounding = 0.0
    guess = 0.0
    peak = 0.0
    out[6] = q0
    evaluated = 0
    status = OK
    processed = 0
    while n_stack > 0:
        processed += 1
        if processed > 4 * _MAX_PANELS:  # a bound on the work, whatever the integrand
            status = NOT_CONVERGED
            break
        n_stack -= 1
        t0 = lo_stack[n_stack]
        t1 = hi_stack[n_stack]
        c = 0.5 * (t0 + t1)
        r = 0.5 * (t1 - t0)
        kron = 0.0
        gauss = 0.0
        noise = 0.0
        for j in range(15):
            if j < 7:
                x = -_XK[j]
                wk = _WK[j]
                wg = _WG[j // 2] if j % 2 == 1 else 0.0
            elif j == 7:
                x = 0.0
                wk = _WK[7]
                wg = _WG[3]
            else:
                x = _XK[14 - j]
                wk = _WK[14 - j]
                wg = _WG[(14 - j) // 2] if (14 - j) % 2 == 1 else 0.0
            theta = c + r * x
            s2 = math.sin(0.5 * theta)
            if theta <= 0.5 * math.pi:
                dist = (b - a) * s2 * s2
                q = a + dist
                slope = slope_a
            else:
                c2 = math.cos(0.5 * theta)
                dist = (b - a) * c2 * c2
                q = b - dist
                slope = slope_b
            vq = value(par, q)
            gap = energy - vq
            evaluated += 1
            if not (gap > 0.0) and dist < 1e-6 * (b - a):
                gap = slope * dist  # at a turning point V(q) rounds to E: linearise
            if not (gap > 0.0):
                out[6] = q
                status = BARRIER
                break
            f = half * math.sin(theta) / math.sqrt(2.0 * gap)
            if f > peak:
                peak = f
                out[6] = q
            kron += wk * f
            gauss += wg * f
            # rounding of E - V(q) (a few ulps) moves f by half as much, relatively
            noise += wk * f * 2.2e-16 * (abs(energy) + abs(vq)) / gap
        if status != OK:
            break
        kron *= r
        gauss *= r
        noise *= r
        err = abs(kron - gauss)
        if guess == 0.0:
            guess = kron * panels
        if err <= rel * guess * r / math.pi + 10.0 * noise or r < 1e-12:
            total += kron
            if err > 10.0 * noise:  # truncation: adds up
                error += err
            else:  # rounding-dominated: independent from panel to panel, in quadrature
                rounding += max(err, noise) ** 2
        elif n_stack + 2 > _MAX_PANELS:
            status = NOT_CONVERGED
            break
        else:
            lo_stack[n_stack] = t0
            hi_stack[n_stack] = c
            lo_stack[n_stack + 1] = c
            hi_stack[n_stack + 1] = t1
            n_stack += 2
    out[0] = 2.0 * total
    out[1] = 2.0 * (error + math.sqrt(rounding)) + 4e-16 * out[0] * math.sqrt(evaluated)
    return status


_orbit_period_jit = numba.njit(**JIT_FN_ARG)(orbit_period)


# Templates compiled once per (value, force) or fn and cached on disk (specialised: the
# period inlined into one row, called by name from the parallel loop); the functions of
# the same names below take the compiled functions as arguments.


def _orbit_row(par, q0, p0, rate, out):
    return _orbit_period_jit(VALUE, FORCE, par, q0, p0, rate, out)


def _batch_orbit_period(pars, rows, q0s, p0s, rates, out, status):
    for k in numba.prange(rows.shape[0]):
        i = rows[k]
        status[k] = _orbit_row(pars[i], q0s[i], p0s[i], rates[k], out[k])


def _pairwise(pars, xs, out):
    for i in numba.prange(xs.shape[0]):
        out[i] = FN(pars[i], xs[i])


def _rowwise(pars, xs, out):
    last = pars.shape[0] - 1
    for i in range(xs.shape[0]):
        par = pars[min(i, last)]
        for j in range(xs.shape[1]):
            out[i, j] = FN(par, xs[i, j])


def batch_orbit_period(value, force, pars, rows, q0s, p0s, rates, out, status):
    """orbit_period of rows ``rows`` (indices into pars, q0s, p0s) with drift rates
    ``rates`` (one per row of ``rows``); out (len(rows), 7)."""
    row = specialised(_orbit_row, {"VALUE": value, "FORCE": force})
    specialised(_batch_orbit_period, {"_orbit_row": row}, parallel=True)(
        pars, rows, q0s, p0s, rates, out, status)


def pairwise(fn, pars, xs, out):
    """out[i] = fn(pars[i], xs[i])."""
    specialised(_pairwise, {"FN": fn}, parallel=True)(pars, xs, out)


def rowwise(fn, pars, xs, out):
    """out[i, j] = fn(pars[i], xs[i, j]); one row of ``pars`` serves every row.

    One call for a whole (N, M) array: a compiled call costs a few µs to dispatch,
    more than the M evaluations of a short row."""
    specialised(_rowwise, {"FN": fn})(pars, xs, out)
