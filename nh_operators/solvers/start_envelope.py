"""Which rows may start the doubling coarse: the envelope the coarse starts were checked in.

A coarse start (:mod:`.start_level`) missed tol only on orbits that are slow somewhere:
released at rest where the force almost vanishes, passing just over a barrier top, turning
where V' almost vanishes, or leaving [0, 1] over a wall as high as their energy
(``benchmarks/promise/sensor_contract.py`` on 6,000 out-of-distribution rows: every
answer over tol had a release force ≤ 0.18, a barrier margin ≤ 5e-7 or a turning slope
≤ 0.007). Near such a point the trajectory's timing depends on its energy without bound
(the period diverges at a separatrix), so the levels' errors are far from the method's
rate, and three coarse levels can agree before any has reached tol. The generator's
potentials never come close: from rest their release force is ≥ 0.42 and their barrier
margin ≥ 0.21 (Algorithm 1 and the paper's, 12,000 rows).

:func:`row_flags` samples each row's potential over [−1/16, 17/16] (a B-spline curve along
its own parameter), marches from its start both ways to the turns, and admits a row only
with margins from all four: its energy clears every barrier top it
passes by :data:`BARRIER_MARGIN`, it turns (and, released at rest, starts) where
``|V'|`` ≥ :data:`TURNING_FORCE`, it stays inside the sampled range, and its kinetic energy
stays ≤ :data:`KINETIC_MAX` (a faster particle steps farther per step). Every other row
starts at :data:`~.start_level.RESOLVED_STEP`.
"""

import warnings

import numba
import numpy as np
from numba.extending import register_jitable

from ..potentials._spline_kernels import (FORCE, JIT, OUTSIDE_MARGIN, VALUE, bspline_force,
                                          bspline_value, cubic, specialised)
from ..potentials.bspline import Q_OFFSET, V_OFFSET

__all__ = ["BARRIER_MARGIN", "INSIDE", "KINETIC_MAX", "PAST_GUARD", "SAMPLES", "TURNING_FORCE",
           "inside_envelope", "orbit_flags", "row_flags"]

#: The least E − V at a barrier top the orbit passes (the generator's least: 0.21).
BARRIER_MARGIN = 0.1
#: The least ``|V'|`` where the orbit turns or is released at rest (the generator's: 0.42).
TURNING_FORCE = 0.2
#: The largest kinetic energy E − V on the orbit (the generator's: 3.98, E = V0 = 2 over
#: V ≥ −2).
KINETIC_MAX = 4.5
#: Samples of V per unit of q for sensor splines and formulas (a B-spline curve: 8 per
#: piece of its curve parameter, its own q, no inversion).
SAMPLES = 256
#: E − V at a sample that counts as a turn there: the generator's walls are as high as
#: the energy, V(1) = V(0) = V0, which rounding may leave a few ulps below it.
_TOUCH = 1e-9
#: The sample points of sensor splines and formulas: [0, 1] and 1/16 past each end (a
#: turn at the end of the domain lies there).
_GRID = np.arange(-SAMPLES // 16, SAMPLES + SAMPLES // 16 + 1) / SAMPLES


@register_jitable
def _turn_slope(xa, va, xb, vb, xc, vc, energy):
    """``|V'|`` at the turn between xb (E > V) and xc (E ≤ V): the smaller of the secant's
    slope and that of the parabola through the last three samples at the turn's linear
    estimate (near a flat top the secant over a sample spacing is ``|V''| h / 2``, far above
    the slope where the orbit turns)."""
    secant = abs(vc - vb) / abs(xc - xb)
    if not np.isfinite(va):  # only two samples: the turn lies next to q0
        return secant
    xt = xb + (xc - xb) * min(max((energy - vb) / (vc - vb), 0.0), 1.0)
    # Newton's divided differences: P'(x) = f[b,c] + f[a,b,c] (2x - b - c)
    fbc = (vc - vb) / (xc - xb)
    fabc = (fbc - (vb - va) / (xb - xa)) / (xc - xa)
    return min(secant, abs(fbc + fabc * (2.0 * xt - xb - xc)))


#: Bits of :func:`orbit_flags`: the orbit keeps the envelope's margins; it reaches past
#: ``OUTSIDE_MARGIN`` (or leaves the samples), where the force of a sensor spline or a
#: B-spline curve is held at its end value, so V has a kink there.
INSIDE, PAST_GUARD = 1, 2


@numba.njit(**JIT)
def orbit_flags(x, v, q0, p0, v0, f0):
    """:data:`INSIDE` | :data:`PAST_GUARD` of the orbit from (q0, p0), on samples (x, v)
    of V (x increasing); ``v0``, ``f0``: V and −V' at q0.

    From q0 it marches over the samples both ways until E − V ≤ 0 (a turn). It is not
    inside at a turn whose slope (the smaller of the secant's and the parabola's through
    the last three samples) is below :data:`TURNING_FORCE`, a sampled top passed with
    E − V below :data:`BARRIER_MARGIN`, a kinetic energy above :data:`KINETIC_MAX`, or the
    end of the samples (the orbit leaves them, and is counted past the guard too).
    """
    kinetic0 = 0.5 * p0 * p0
    # (nearly) at rest where the force (nearly) vanishes
    inside = not (kinetic0 < BARRIER_MARGIN and abs(f0) < TURNING_FORCE)
    past = False
    energy = kinetic0 + v0
    j = np.searchsorted(x, q0, side="right")
    for direction in (-1, 1):
        if p0 == 0.0 and direction * f0 <= 0.0:
            continue  # released at rest: q0 is the turn on this side (|f0| checked)
        k = j if direction == 1 else j - 1
        xb, vb, xbb, vbb = q0, v0, np.nan, np.inf  # the point behind, and two behind
        while True:
            if k < 0 or k >= x.shape[0]:
                inside, past = False, True
                break
            xk, vk = x[k], v[k]
            if xk == xb:  # q0 on a sample
                k += direction
                continue
            past = past or xk < -OUTSIDE_MARGIN or xk > 1.0 + OUTSIDE_MARGIN
            if not energy - vk > _TOUCH * (1.0 + abs(energy)):  # a turn by xk
                inside = inside and _turn_slope(xbb, vbb, xb, vb, xk, vk,
                                                energy) >= TURNING_FORCE
                break
            if energy - vk > KINETIC_MAX:
                inside = False
            if vb >= vbb and vb >= vk and energy - vb < BARRIER_MARGIN:
                inside = False  # a top at xb, passed slowly
            xbb, vbb, xb, vb = xb, vb, xk, vk
            k += direction
    return INSIDE * inside + PAST_GUARD * past


def _grid_rows(pars, q0s, p0s, out):
    last = pars.shape[0] - 1
    for i in numba.prange(q0s.shape[0]):
        par = pars[min(np.int64(i), last)]  # (a prange index is unsigned: min would float)
        v = np.empty(_GRID.shape[0])
        for k in range(_GRID.shape[0]):
            v[k] = VALUE(par, _GRID[k])
        out[i] = orbit_flags(_GRID, v, q0s[i], p0s[i], VALUE(par, q0s[i]),
                                FORCE(par, q0s[i]))


@numba.njit(**JIT)
def _curve_rows(pars, q0s, p0s, out):
    for i in range(q0s.shape[0]):
        par = pars[i]
        pieces = int(par[0])
        x = np.empty(8 * pieces + 3)
        v = np.empty_like(x)
        x[0] = cubic(par, Q_OFFSET, -0.125)  # the end pieces continued by 1/8
        v[0] = cubic(par, V_OFFSET, -0.125)
        for j in range(pieces):
            for k in range(8):
                x[1 + 8 * j + k] = cubic(par, Q_OFFSET + 4 * j, k / 8.0)
                v[1 + 8 * j + k] = cubic(par, V_OFFSET + 4 * j, k / 8.0)
        for k, s in enumerate((1.0, 1.125)):
            x[1 + 8 * pieces + k] = cubic(par, Q_OFFSET + 4 * (pieces - 1), s)
            v[1 + 8 * pieces + k] = cubic(par, V_OFFSET + 4 * (pieces - 1), s)
        out[i] = orbit_flags(x, v, q0s[i], p0s[i], bspline_value(par, q0s[i]),
                                bspline_force(par, q0s[i]))


def row_flags(src, q0s, p0s):
    """:func:`orbit_flags` of every row (:data:`INSIDE` | :data:`PAST_GUARD`).

    Args:
        src: a :class:`~.rows.RowSource` (one row of parameters for a formula).
        q0s, p0s: (N,) starting states.

    Returns:
        (N,) int64.
    """
    q0s = np.ascontiguousarray(q0s, dtype=np.float64)
    p0s = np.ascontiguousarray(p0s, dtype=np.float64)
    out = np.zeros(q0s.size, dtype=np.int64)
    if src.curve:
        _curve_rows(src.params, q0s, p0s, out)
    elif src.compiled:
        specialised(_grid_rows, {"VALUE": src.value, "FORCE": src.force}, parallel=True)(
            src.params, q0s, p0s, out)
    else:  # a formula in Python: no compiler (a first solve starts none)
        par = src.params[0]
        try:  # a callable may refuse (or warn about) q outside [0, 1]: then no coarse start
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                v = np.array([src.value(par, x) for x in _GRID])
                for i in range(q0s.size):
                    out[i] = orbit_flags.py_func(_GRID, v, q0s[i], p0s[i],
                                                 src.value(par, q0s[i]),
                                                 src.force(par, q0s[i]))
        except Exception:  # noqa: BLE001 (any refusal of the samples means: outside)
            out[:] = 0
    return out


def inside_envelope(src, q0s, p0s):
    """Per row (N,), whether its orbit keeps the margins of the module (see there); the
    arguments of :func:`row_flags`.

    Example:
        >>> import numpy as np
        >>> from nh_operators.solvers.rows import row_source
        >>> x = np.linspace(0, 1, 100)
        >>> V = np.stack([2.0 * (1.0 - 2.0 * x) ** 2,  # a well
        ...               2.0 * np.cos(2 * np.pi * x) ** 2])  # a top at 1/2 at V = 2
        >>> inside_envelope(row_source(V, "sensors"), np.zeros(2), np.zeros(2)).tolist()
        [True, False]
    """
    return (row_flags(src, q0s, p0s) & INSIDE) > 0
