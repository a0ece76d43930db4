"""The period of a bounded 1-D orbit: turning points and an adaptive quadrature of dq/|p|.

:func:`orbit_period` runs four named steps: a point near the start where the particle
moves and a turning point on each side (:mod:`._turning_points`), the orbits without a
period (:func:`_degenerate`), and the quadrature (:func:`_period_quadrature`, panel by
panel).

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

Why one source: the algorithm is written once as plain Python and compiled with numba
for every potential whose ``value(par, x)`` and ``force(par, x)`` are compiled functions
(B-splines, sensor splines, compiled formulas); a potential only known as a Python
callable runs the same source uncompiled (``orbit_period`` itself). The steps that call
``value`` or ``force`` are ``register_jitable`` (plain Python, compiled where a compiled
function calls them); the others are cached ``njit`` kernels. numba's disk cache of the
kernels below checks this file only: after editing :mod:`._turning_points`, clear it.
"""

import math

import numba
import numpy as np
from numba.extending import register_jitable

from ..potentials._spline_kernels import FORCE, VALUE, JIT, JIT_FN_ARG, specialised
from ._turning_points import inside_start, turning_point

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

_MAX_PANELS = 4000
#: The finest relative accuracy of the period asked for (about what float64 resolves).
REL_FINEST = 1e-14
#: The coarsest: a period known to worse than 1e-8 relative is not used (.periodic).
REL_COARSEST = 1e-9
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
    x_in, fixed_side, moves = inside_start(value, force, par, q0, energy)
    if not moves:
        return _at_rest(out, q0)
    ends = np.empty(2)
    flat = np.full(2, math.inf)  # |V'| at the turning points found inside
    smax_p = 0.0  # bounds on p² and V'² along the orbit
    smax_f = 0.0
    for side in range(2):
        direction = -1.0 if side == 0 else 1.0
        if (side == 0 and fixed_side == -1) or (side == 1 and fixed_side == 1):
            ends[side] = q0
            continue
        end, slope, smax_p, smax_f = turning_point(value, force, par, energy, x_in,
                                                   direction, smax_p, smax_f)
        ends[side] = end
        flat[side] = slope
    a = ends[0]
    b = ends[1]
    fq = force(par, q0)
    out[2] = a
    out[3] = b
    out[4] = max(smax_p, 2.0 * (energy - value(par, q0))) + max(smax_f, fq * fq)
    status = _degenerate(value, par, energy, q0, ends, flat, smax_p, max(smax_f, fq * fq),
                         out)
    if status != OK:
        return status
    rel = _aimed_accuracy(rate, out[4])
    return _period_quadrature(value, force, par, energy, q0, a, b, rel, out)


@register_jitable(inline="always")
def _degenerate(value, par, energy, q0, ends, flat, smax_p, smax_f, out):
    """STATIONARY, BARRIER (with ``out`` filled) or OK (a period to integrate).

    An orbit whose kinetic energy is at the rounding level of E is at rest (its motion,
    of amplitude ~ sqrt(ulp), is below what E − V(q) resolves); a turning point where V'
    vanishes (below :data:`_FLAT` of the largest |V'|, ``smax_f`` its square) is a
    barrier top reached at zero speed.
    """
    a = ends[0]
    b = ends[1]
    kinetic = max(energy - value(par, 0.5 * (a + b)), energy - value(par, q0), 0.5 * smax_p)
    if kinetic <= 1e-15 * (1.0 + abs(energy)):
        out[0] = math.inf
        out[1] = 0.0
        out[6] = q0
        return STATIONARY
    for side in range(2):
        if flat[side] < _FLAT * math.sqrt(smax_f):
            out[0] = math.inf
            out[1] = math.inf
            out[6] = ends[side]
            return BARRIER
    return OK


@numba.njit(**JIT)
def _aimed_accuracy(rate, s):
    """The relative accuracy of T that drift ``rate`` allows with S = ``s``."""
    if s > 0.0:
        return min(max(rate / math.sqrt(s), REL_FINEST), REL_COARSEST)
    return REL_FINEST


@register_jitable(inline="always")
def _period_quadrature(value, force, par, energy, q0, a, b, rel, out):
    """T and its error bound (out[0], out[1]) by adaptive Gauss–Kronrod on θ ∈ [0, π],
    from 8 panels; out[6] the q where the integrand peaked. Returns OK, BARRIER (E ≤ V
    inside) or NOT_CONVERGED."""
    slope_a = abs(force(par, a))
    slope_b = abs(force(par, b))
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
        kron, gauss, noise, peak, count, status = _panel(value, par, energy, a, b, slope_a,
                                                         slope_b, c, r, peak, out)
        evaluated += count
        if status != OK:
            break
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


@register_jitable(inline="always")
def _panel(value, par, energy, a, b, slope_a, slope_b, c, r, peak, out):
    """One Gauss–Kronrod (7, 15) panel θ ∈ [c − r, c + r] of the half period.

    The integrand is (b − a)/2 · sin θ / sqrt(2 (E − V(q))); near a turning point, where
    V(q) rounds to E, E − V is linearised. ``peak`` (and out[6], its q) is raised where
    the integrand exceeds it.

    Returns:
        (kron, gauss, noise, peak, evaluated, status): the two rules' integrals over the
        panel, the rounding of E − V carried into them, the values of V taken, and
        BARRIER (out[6] the q) where E ≤ V, else OK.
    """
    half = 0.5 * (b - a)
    kron = 0.0
    gauss = 0.0
    noise = 0.0
    for j in range(15):
        x, wk, wg = _kronrod_node(j)
        theta = c + r * x
        q, dist, slope = _on_orbit(theta, a, b, slope_a, slope_b)
        vq = value(par, q)
        gap = energy - vq
        if not (gap > 0.0) and dist < 1e-6 * (b - a):
            gap = slope * dist  # at a turning point V(q) rounds to E: linearise
        if not (gap > 0.0):
            out[6] = q
            return 0.0, 0.0, 0.0, peak, j + 1, BARRIER
        f = half * math.sin(theta) / math.sqrt(2.0 * gap)
        if f > peak:
            peak = f
            out[6] = q
        kron += wk * f
        gauss += wg * f
        # rounding of E - V(q) (a few ulps) moves f by half as much, relatively
        noise += wk * f * 2.2e-16 * (abs(energy) + abs(vq)) / gap
    return kron * r, gauss * r, noise * r, peak, 15, OK


@numba.njit(**JIT)
def _kronrod_node(j):
    """(x, Kronrod weight, Gauss weight) of node j = 0..14 of the (7, 15) rule on
    [-1, 1], left to right (Gauss weight 0 at the nodes that are Kronrod's only)."""
    if j < 7:
        return -_XK[j], _WK[j], _WG[j // 2] if j % 2 == 1 else 0.0
    if j == 7:
        return 0.0, _WK[7], _WG[3]
    return _XK[14 - j], _WK[14 - j], _WG[(14 - j) // 2] if (14 - j) % 2 == 1 else 0.0


@register_jitable(inline="always")
def _on_orbit(theta, a, b, slope_a, slope_b):
    """(q, its distance to the nearer turning point, |V'| there) at θ, with
    q = a + (b − a) sin²(θ/2) (from the nearer end, to keep its digits)."""
    if theta <= 0.5 * math.pi:
        s2 = math.sin(0.5 * theta)
        dist = (b - a) * s2 * s2
        return a + dist, dist, slope_a
    c2 = math.cos(0.5 * theta)
    dist = (b - a) * c2 * c2
    return b - dist, dist, slope_b


_orbit_period_jit = numba.njit(**JIT_FN_ARG)(orbit_period)


# Templates compiled once per (value, force) and cached on disk (specialised: the period
# inlined into one row, called by name from the parallel loop).


def _orbit_row(par, q0, p0, rate, out):
    return _orbit_period_jit(VALUE, FORCE, par, q0, p0, rate, out)


def _batch_orbit_period(pars, rows, q0s, p0s, rates, out, status):
    for k in numba.prange(rows.shape[0]):
        i = rows[k]
        status[k] = _orbit_row(pars[i], q0s[i], p0s[i], rates[k], out[k])


def batch_orbit_period(value, force, pars, rows, q0s, p0s, rates, out, status):
    """orbit_period of rows ``rows`` (indices into pars, q0s, p0s) with drift rates
    ``rates`` (one per row of ``rows``); out (len(rows), 7)."""
    row = specialised(_orbit_row, {"VALUE": value, "FORCE": force})
    specialised(_batch_orbit_period, {"_orbit_row": row}, parallel=True)(
        pars, rows, q0s, p0s, rates, out, status)
