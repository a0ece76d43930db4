"""When a fixed step is too coarse: the checks behind :class:`ResolutionWarning`.

The fixed-step solvers of :mod:`nh_operators.solvers.fixed_step` call these after (or before) a
solve: the step against the potential's curvature (h·sqrt(max ``|V''|``) against the
method's linear stability limit), the energy drift at the last query time, and, for a
formula, a kink (a jump of the force), across which fixed steps are first order.
"""

import math
import warnings

import numpy as np

from .._constants import V0
from .schemes import ORDERS, step_method, step_grid

__all__ = ["ResolutionWarning", "STABILITY_LIMITS", "RESOLUTION_FRACTION", "ENERGY_DRIFT_TOL",
           "check_resolution_of", "check_energy", "check_formula", "spline_curvature",
           "spline_drift"]

#: Linear stability limit: the largest h ω for which a step of q'' = -ω² q has no eigenvalue
#: of modulus above 1 (RK4 2√2, Verlet 2; Yoshida's by bisection, see test_stability).
STABILITY_LIMITS = {"rk4": 2.0 * math.sqrt(2.0), "verlet": 2.0, "yoshida4": 1.5734,
                    "yoshida6": 1.5954, "yoshida8": 1.5377}
#: A step h is flagged when h·sqrt(max ``|V''|``) exceeds this fraction of the stability limit
#: (RK4: √2, where a step of an oscillation loses 2.6 % of its amplitude). The sensor
#: splines of the generator's 14,000 potentials (standard.h5, test.h5) reach 1.233 at one
#: RK4 step per output interval (PCHIP: 1.164).
RESOLUTION_FRACTION = 0.5
#: ``|p²/2 + V(q) - V0|`` at the last query time above which the step is flagged, by force
#: source. On standard.h5 + test.h5 the cubic-spline drift stays below 0.034 at one RK4
#: step per interval (0.013: two Yoshida-8 steps), PCHIP's (C¹ only) below 0.36; a deep
#: well (min V = -100) drifts by 0.28 at four RK4 steps although h·sqrt(max ``|V''|``) = 0.44.
ENERGY_DRIFT_TOL = {"cubic": 0.1, "pchip": 1.0, "formula": 0.1}
#: Probes of a formula's force (curvature, kinks): spacing 1/2048, offset from q = 1/2.
_PROBE = (np.arange(2048) + 0.381966) / 2048



class ResolutionWarning(UserWarning):
    """A fixed step too coarse for the potential, or a kink that fixed steps cannot resolve."""



def spline_curvature(params):
    """max ``|V''|`` per row of piecewise cubics (V'' is linear on a piece: its ends suffice)."""
    c = params.reshape(params.shape[0], -1, 4)
    start = 2.0 * c[..., 2]
    end = np.abs(start + 6.0 * c[..., 3])
    return np.maximum(np.abs(start, out=start), end).max(axis=1) * c.shape[1] ** 2


def spline_drift(params, q, p, energy=V0):
    """``|p²/2 + V(q) - E|`` on each row's spline, at one point (q, p) per row (E: the
    energy of each row's starting state, default V0)."""
    c = params.reshape(params.shape[0], -1, 4)
    x = np.nan_to_num(np.clip(q, 0.0, 1.0)) * c.shape[1]
    j = np.minimum(x.astype(np.int64), c.shape[1] - 1)
    a, s = c[np.arange(j.size), j].T, x - j
    return np.abs(0.5 * p**2 + a[0] + s * (a[1] + s * (a[2] + s * a[3])) - energy)


def _rows(bad, batched, name):
    more = f" and {bad.size - 5} more" if bad.size > 5 else ""
    return f"{name}[{', '.join(map(str, bad[:5]))}{more}]" if batched else name


def check_energy(drift, t, method, substeps, source, batched, name="V"):
    """Warn if the energy at the last query time drifted by more than ENERGY_DRIFT_TOL."""
    tol = ENERGY_DRIFT_TOL[source]
    bad = np.flatnonzero(~(drift <= tol))
    if bad.size:
        e, goal, order = np.nan_to_num(drift[bad], nan=np.inf).max(), 0.01, ORDERS[method]
        need = (f"about {math.ceil(substeps * (e / goal) ** (1 / order))} substeps bring it "
                f"below {goal:g} (at order {order})" if np.isfinite(e) else "use more substeps")
        warnings.warn(f"the energy of {_rows(bad, batched, name)} drifted by {e:.3g} by t = "
                      f"{t.max():.4g} with {method} at {substeps} substep(s), more than "
                      f"{tol:g}: the step is too coarse for this potential; {need}",
                      ResolutionWarning, stacklevel=3)


def check_resolution_of(curvature, t, method, substeps, interval, batched, name="V", level=3):
    """Warn if h·sqrt(max ``|V''|``) exceeds RESOLUTION_FRACTION of the stability limit."""
    step_method(method)
    limit = RESOLUTION_FRACTION * STABILITY_LIMITS[method]
    h, nsteps = step_grid(t, substeps, interval)[2:]
    x = h * np.sqrt(np.asarray(curvature, dtype=np.float64))
    bad = np.flatnonzero(x > limit) if nsteps else np.array([], dtype=int)
    if bad.size:
        worst = bad[np.argmax(x[bad])]
        need = max(math.ceil(substeps * x[worst] / limit), substeps + 1)
        while x[worst] / h * step_grid(t, need, interval)[2] > limit:
            need += 1
        warnings.warn(f"step h = {h:.4g} ({substeps} substep(s)) is too coarse for the "
                      f"curvature of {_rows(bad, batched, name)}: h·sqrt(max|V''|) = "
                      f"{x[worst]:.3g} (max|V''| = {curvature[worst]:.4g}) exceeds {limit:.3g}, "
                      f"{RESOLUTION_FRACTION:g} of {method}'s stability limit "
                      f"{STABILITY_LIMITS[method]:.4g}; use substeps >= {need}",
                      ResolutionWarning, stacklevel=level)


def check_formula(potential, t, method, substeps, interval):
    """Probe a formula's force on a fine grid: a kink warns, else the curvature is checked."""
    with np.errstate(all="ignore"):
        f = np.broadcast_to(np.asarray(potential.dV(_PROBE), dtype=np.float64), _PROBE.shape)
    if not np.all(np.isfinite(f)):
        return
    fine = np.abs(np.diff(f))  # spacing δ = 1/2048; over 2δ a smooth force changes twice as much
    jump = fine.max()
    if jump > 1e-8 * (1.0 + np.abs(f).max()) and np.abs(f[2:] - f[:-2]).max() < 1.5 * jump:
        warnings.warn(f"dV jumps by {jump:.3g} near q = {_PROBE[np.argmax(fine)]:.3f} (a kink, "
                      "or a feature narrower than 1/2048): fixed steps converge only to first "
                      "order across it, whatever the substeps; reference_solve is adaptive",
                      ResolutionWarning, stacklevel=3)
    else:
        check_resolution_of(np.array([jump * 2048]), t, method, substeps, interval, False,
                          getattr(potential, "name", "V"), level=4)
