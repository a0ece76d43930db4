"""The turning points of a bounded 1-D orbit: a march on a grid, then regula falsi.

From a point where the particle moves (E > V), :func:`turning_point` steps 1/256 at a
time towards a wall until E − V changes sign (:func:`_march`); the differences of V
between samples bound |V'| (mean value theorem) and E − V at them bounds p², the two
parts of S in :func:`~._orbit.orbit_period`. Where the samples peak below E, a barrier top
between them is looked for by golden section (:func:`_barrier_top`), in case it reaches E
there. The bracket is then pinned down to adjacent floats by the Illinois variant of
regula falsi, safeguarded by bisection (:func:`_pin_down`, ~10 values a side instead of
the ~50 of bisection alone).

Why ``register_jitable``: like :func:`~._orbit.orbit_period`, these steps run uncompiled
with Python callables for ``value`` and ``force``, and compiled (inside the period's
cached kernels) with compiled ones: one source for both.
"""

import math

from numba.extending import register_jitable

__all__ = ["inside_start", "turning_point"]

_MARCH = 1.0 / 256.0  # grid on which the turning points are bracketed
_OUTSIDE = 0.05  # how far past a wall a turning point is looked for
_GOLDEN = 0.5 * (math.sqrt(5.0) - 1.0)


@register_jitable(inline="always")
def inside_start(value, force, par, q0, energy):
    """(x_in, fixed_side, moves): where the marches to the turning points start.

    q0 itself when E > V(q0). Released at rest (E = V(q0)), q0 is a turning point
    (``fixed_side`` −1: the left one, 1: the right one) and x_in the first point towards
    the force, within 1/256 and halving the step, where E > V; ``moves`` is False when
    there is none (or no force): the particle stays at q0.
    """
    if energy - value(par, q0) > 0.0:
        return q0, 0, True
    f0 = force(par, q0)
    if f0 == 0.0:
        return q0, 0, False
    direction = 1.0 if f0 > 0.0 else -1.0
    fixed_side = -1 if f0 > 0.0 else 1
    step = _MARCH
    for _ in range(40):
        x = min(max(q0 + direction * step, 0.0), 1.0)
        if energy - value(par, x) > 0.0:
            return x, fixed_side, True
        step *= 0.5
    return q0, fixed_side, False


@register_jitable(inline="always")
def turning_point(value, force, par, energy, x_in, direction, smax_p, smax_f):
    """The turning point from x_in towards ``direction`` (−1: left, 1: right).

    Returns:
        (end, |V'(end)|, smax_p, smax_f): the turning point (a point past a wall when E
        exceeds V there, with |V'| inf), and the bounds on p² and V'² grown by the march.
    """
    x, v, xn, vn, wall, smax_p, smax_f = _march(value, par, energy, x_in, direction,
                                                smax_p, smax_f)
    if wall:
        return xn, math.inf, smax_p, smax_f
    lo = _pin_down(value, par, energy, x, energy - v, xn, energy - vn)
    fe = force(par, lo)
    return lo, abs(fe), smax_p, max(smax_f, fe * fe)


@register_jitable(inline="always")
def _march(value, par, energy, x_in, direction, smax_p, smax_f):
    """Step 1/256 at a time from x_in until E − V changes sign.

    The differences of V between samples bound V'² (mean value theorem) and E − V at
    them p²; where the samples peak, a barrier top between them is looked for
    (:func:`_barrier_top`) in case it reaches E there.

    Returns:
        (x, V(x), xn, V(xn), wall, smax_p, smax_f): E > V at x and E ≤ V at xn (the
        bracket of the turning point), or ``wall`` when xn went past a wall by
        :data:`_OUTSIDE`.
    """
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
            # V peaks between x_back and xn, where the samples stay below E
            top, v_top = _barrier_top(value, par, min(x_back, xn), max(x_back, xn))
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
    return x, v, xn, vn, wall, smax_p, smax_f


@register_jitable(inline="always")
def _barrier_top(value, par, ga, gb):
    """(top, V(top)): the maximum of V on [ga, gb] by golden-section search, to 1e-13
    (V is flat at a top: its value right to ~1e-26)."""
    gc, gd = gb - _GOLDEN * (gb - ga), ga + _GOLDEN * (gb - ga)
    vc, vd = value(par, gc), value(par, gd)
    while gb - ga > 1e-13:
        if vc >= vd:
            gb, gd, vd = gd, gc, vc
            gc = gb - _GOLDEN * (gb - ga)
            vc = value(par, gc)
        else:
            ga, gc, vc = gc, gd, vd
            gd = ga + _GOLDEN * (gb - ga)
            vd = value(par, gd)
    return (gc, vc) if vc >= vd else (gd, vd)


@register_jitable(inline="always")
def _pin_down(value, par, energy, lo, glo, hi, ghi):
    """The turning point between lo (g = E − V = glo > 0) and hi (ghi ≤ 0), to two
    adjacent floats: the Illinois variant of regula falsi, bisecting whenever the bracket
    does not halve in two steps. Returns the last point inside (g > 0)."""
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
    return lo
