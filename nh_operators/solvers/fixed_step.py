"""Classical solvers of q' = p, p' = -V'(q) from rest at q = 0, in float64.

- :func:`integrate`: fixed-step RK4 and symplectic methods on a potential known exactly.
- :func:`integrate_sensors`: the same methods on the information a neural operator has,
  V at the 100 :data:`SENSORS`, the force from a spline of the sensors.
- :func:`paper_rk4`: the paper's RK4 row, rebuilt correctly (one RK4 step per output
  interval, force from a PCHIP interpolant) so that it can be shown for what it is.
- :func:`reference_solve`: adaptive high-accuracy solve used for truth.

The fixed-step solvers warn with :class:`ResolutionWarning` when the step is too coarse
for the potential's curvature (:data:`RESOLUTION_FRACTION`), when the energy has drifted
by :data:`ENERGY_DRIFT_TOL` at the last query time (sensor splines and formulas), or when
a formula's force jumps (a kink: fixed steps are then first order).
"""

import numpy as np
from scipy import integrate as sp_integrate
from scipy import interpolate

from . import _kernels
from ._constants import SENSORS, TIMES, V0
from .potentials import BoundedPotential, check_bounded
from .resolution import (ENERGY_DRIFT_TOL, RESOLUTION_FRACTION, STABILITY_LIMITS,
                         ResolutionWarning, check_energy, check_formula,
                         check_resolution_of, spline_curvature, spline_drift)

__all__ = ["METHODS", "ORDERS", "RESOLUTION_FRACTION", "STABILITY_LIMITS", "ENERGY_DRIFT_TOL",
           "ResolutionWarning", "integrate", "integrate_sensors", "paper_rk4", "reference_solve"]


def _triple_jump(weights, order):
    """Yoshida's triple jump: a method of even order ``order`` from one of order - 2."""
    root = 2.0 ** (1.0 / (order - 1))
    w1 = 1.0 / (2.0 - root)
    w0 = -root * w1
    return np.concatenate([w1 * weights, w0 * weights, w1 * weights])


_VERLET = np.array([1.0])
_Y4 = _triple_jump(_VERLET, 4)
_Y6 = _triple_jump(_Y4, 6)
_Y8 = _triple_jump(_Y6, 8)

#: Step methods: None means classical RK4; otherwise the Störmer–Verlet sub-step weights
#: of a symplectic composition (Yoshida's triple jump for orders 4, 6 and 8).
METHODS = {"rk4": None, "verlet": _VERLET, "yoshida4": _Y4, "yoshida6": _Y6, "yoshida8": _Y8}
#: Convergence order of each method on smooth potentials.
ORDERS = {"rk4": 4, "verlet": 2, "yoshida4": 4, "yoshida6": 6, "yoshida8": 8}
def _check_times(t):
    t = np.asarray(t, dtype=np.float64)
    if t.ndim == 2 and t.shape[1] == 1:
        t = t[:, 0]
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"t must be a non-empty 1-D array of times, got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ValueError("t must hold finite times ≥ 0 (the particle starts at rest at t = 0)")
    return t


def _step_grid(t, substeps, interval):
    """Sorted query times, step size and number of steps covering [0, max t]."""
    if not (isinstance(substeps, (int, np.integer)) and substeps >= 1):
        raise ValueError(f"substeps must be a positive integer, got {substeps}")
    order = np.argsort(t, kind="stable")
    ts = np.ascontiguousarray(t[order])
    if interval is None:
        interval = TIMES[1] - TIMES[0]
        if ts.size >= 2 and ts[0] == 0.0:
            gaps = np.diff(ts)
            if gaps[0] > 0 and np.abs(gaps - gaps[0]).max() <= 1e-9 * gaps[0]:
                interval = gaps[0]
    if not interval > 0:
        raise ValueError(f"interval must be positive, got {interval}")
    t_max = ts[-1]
    nsteps = int(np.ceil(t_max * substeps / interval - 1e-9)) if t_max > 0 else 0
    h = t_max / nsteps if nsteps else 1.0
    return order, ts, h, nsteps


def _method(method):
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {sorted(METHODS)}")
    weights = METHODS[method]
    return weights is None, (_VERLET if weights is None else weights)


def _run_fixed(force, params, t, method, substeps, interval):
    rk4, weights = _method(method)
    order, ts, h, nsteps = _step_grid(t, substeps, interval)
    n = params.shape[0]
    oq = np.empty((n, ts.size))
    op = np.empty((n, ts.size))
    _kernels.batch_fixed(force, params, ts, h, nsteps, rk4, weights, oq, op)
    q = np.empty_like(oq)
    p = np.empty_like(op)
    q[:, order] = oq
    p[:, order] = op
    return q, p


def integrate(potential, t=TIMES, method="rk4", substeps=1, *, interval=None,
              check_resolution=True):
    """Integrate Hamilton's equations with a fixed-step method on an exact potential.

    The step is ``interval / substeps``, adjusted down so that a whole number of steps
    ends at max(t). ``interval`` defaults to the spacing of t when t is an even grid
    starting at 0 (so every query lands on a step), else to the spacing of
    :data:`TIMES`. Other query times come from cubic Hermite interpolation of the step
    ends with the exact derivatives dq/dt = p and dp/dt = -V'(q).

    Args:
        potential: a :class:`BoundedPotential` (single or batch: compiled, parallel), or
            any object with a vectorised ``dV(q)`` (for example a value of
            :data:`PHYSICAL_POTENTIALS`; integrated in Python, one at a time), or a
            list of such objects.
        t: query times, shape (M,) or (M, 1), all ≥ 0, in any order.
        method: ``"rk4"``, ``"verlet"``, ``"yoshida4"``, ``"yoshida6"`` or ``"yoshida8"``.
        substeps: steps per output interval (a positive integer).
        interval: the output interval (see above).
        check_resolution: warn when the step is too coarse (a B-spline's curvature is
            probed at the sensors, a third of the cost of a one-substep solve).

    Returns:
        (q, p): float64 arrays of shape (M,) for one potential, (N, M) for a batch.

    Raises:
        ValueError: for an unknown method, bad times or substeps.
        TypeError: if the potential has no ``dV``.

    Warns:
        ResolutionWarning: when ``h·sqrt(max |V''|)`` exceeds :data:`RESOLUTION_FRACTION` of
            the method's stability limit (the message names the substeps that suffice);
            for a formula, also when its force jumps (a kink) or its energy drifts by
            more than :data:`ENERGY_DRIFT_TOL`.

    Example:
        >>> from nh_operators import PHYSICAL_POTENTIALS
        >>> q, p = integrate(PHYSICAL_POTENTIALS["sho"], [0.0, 0.5], substeps=64)
        >>> round(float(q[1]), 6)  # exact: (1 - cos 2) / 2
        0.708073
    """
    t = _check_times(t)
    if isinstance(potential, BoundedPotential):
        q, p = _run_fixed(_kernels.bspline_force, potential.params, t, method, substeps, interval)
        if check_resolution:
            curvature = np.abs(potential.d2V(SENSORS)).reshape(-1, SENSORS.size).max(axis=1)
            check_resolution_of(curvature, t, method, substeps, interval, potential.batched)
        return (q, p) if potential.batched else (q[0], p[0])
    if isinstance(potential, (list, tuple)):
        pairs = [integrate(pot, t, method, substeps, interval=interval,
                           check_resolution=check_resolution) for pot in potential]
        return np.stack([a for a, _ in pairs]), np.stack([b for _, b in pairs])
    if not hasattr(potential, "dV"):
        raise TypeError(
            "potential must be a BoundedPotential or have a vectorised dV(q) method; for "
            "values at the sensors use integrate_sensors"
        )
    if check_resolution:
        check_formula(potential, t, method, substeps, interval)
    rk4, weights = _method(method)
    order, ts, h, nsteps = _step_grid(t, substeps, interval)
    oq = np.empty(ts.size)
    op = np.empty(ts.size)

    def force(_params, x):
        return -float(potential.dV(x))

    _kernels._trajectory_fixed.py_func(force, None, ts, h, nsteps, rk4, weights, oq, op)
    q = np.empty_like(oq)
    p = np.empty_like(op)
    q[order] = oq
    p[order] = op
    if check_resolution and hasattr(potential, "V"):
        with np.errstate(all="ignore"):
            drift = abs(0.5 * op[-1] ** 2 + float(potential.V(oq[-1])) - V0)
        check_energy(np.array([drift]), t, method, substeps, "formula", False,
                      getattr(potential, "name", "V"))
    return q, p


def _piece_coefficients(c):
    """scipy's (4, 99, N) power coefficients -> (N, 396) per-piece in s = 99 q - j."""
    width = SENSORS[1] - SENSORS[0]
    c = c[::-1] * (width ** np.arange(4))[:, None, None]  # lowest power first
    return np.ascontiguousarray(np.transpose(c, (2, 1, 0)).reshape(c.shape[2], -1))


def sensor_spline_params(V, interpolation="cubic"):
    """Per-piece cubic coefficients of a spline through the sensor values.

    Args:
        V: (N, 100) values at :data:`SENSORS`.
        interpolation: ``"cubic"`` (not-a-knot cubic spline) or ``"pchip"``.

    Returns:
        float64 array (N, 4 * 99): on piece j, coefficients a0..a3 of the cubic in
        s = 99 q - j ∈ [0, 1].
    """
    if interpolation == "cubic":  # compiled, row by row: ~3 µs for one potential
        V = np.ascontiguousarray(V, dtype=np.float64)
        out = np.empty((V.shape[0], 4 * (V.shape[1] - 1)))
        _kernels.notaknot_params(V, out)
        return out
    if interpolation == "pchip":
        spline = interpolate.PchipInterpolator(SENSORS, V, axis=1)
    else:
        raise ValueError(f"interpolation must be 'cubic' or 'pchip', got {interpolation!r}")
    return _piece_coefficients(spline.c)


def integrate_sensors(V, t=TIMES, method="rk4", substeps=1, interpolation="cubic", *,
                      interval=None, check_resolution=True):
    """Integrate with the force from a spline of the sensor values: the honest baseline.

    A neural operator sees V only at the 100 :data:`SENSORS`; this solver uses the same
    information. With ``interpolation="cubic"`` the force is -V' of the not-a-knot cubic
    spline of the sensors; ``"pchip"`` uses the shape-preserving PCHIP interpolant.

    Args:
        V: sensor values, shape (100,) or (N, 100); checked with :func:`check_bounded`.
        t, method, substeps, interval: as in :func:`integrate`.
        interpolation: ``"cubic"`` or ``"pchip"``.
        check_resolution: warn when the step is too coarse (negligible cost).

    Returns:
        (q, p) of shape (M,) or (N, M).

    Raises:
        ValueError: if V breaks the bounded conditions or has the wrong shape.

    Warns:
        ResolutionWarning: naming the rows where ``h·sqrt(max |V''|)`` of the spline
            exceeds :data:`RESOLUTION_FRACTION` of the method's stability limit, or the
            energy drifts by more than :data:`ENERGY_DRIFT_TOL`, and the substeps that
            suffice. A feature narrower than the sensor spacing is invisible to the spline.

    Example:
        >>> V = 8 * (SENSORS - 0.5) ** 2
        >>> q, p = integrate_sensors(V, substeps=4)
        >>> q.shape
        (100,)
    """
    t = _check_times(t)
    V = check_bounded(V)
    single = V.ndim == 1
    params = sensor_spline_params(np.atleast_2d(V), interpolation)
    if check_resolution:
        check_resolution_of(spline_curvature(params), t, method, substeps, interval, not single)
    q, p = _run_fixed(_kernels.grid_force, params, t, method, substeps, interval)
    if check_resolution:
        last = int(np.argmax(t))
        check_energy(spline_drift(params, q[:, last], p[:, last]), t, method, substeps,
                      interpolation, not single)
    return (q[0], p[0]) if single else (q, p)


def paper_rk4(V, t=TIMES):
    """The paper's RK4 baseline done correctly: one RK4 step per output interval, PCHIP force.

    Args:
        V: sensor values, shape (100,) or (N, 100).
        t: query times (default :data:`TIMES`).

    Returns:
        (q, p) of shape (M,) or (N, M).
    """
    return integrate_sensors(V, t, method="rk4", substeps=1, interpolation="pchip")


def reference_solve(potential, t=TIMES, *, rtol=1e-15, atol=1e-15, full_output=False,
                    max_steps=10_000_000):
    """High-accuracy solve used for truth.

    For a :class:`BoundedPotential` the equations are solved in the curve parameter λ of
    the B-spline (λ' = p / q'(λ), p' = -V'(λ) / q'(λ)), which needs no inversion of q(λ),
    by an adaptive Dormand–Prince 5(4) method that lands exactly on every query time
    (compiled, parallel over the batch). Any other potential with ``dV`` is solved by
    scipy's DOP853 at ``rtol = atol = 1e-13``.

    Args:
        potential: a :class:`BoundedPotential` (single or batch) or an object with
            ``dV``.
        t: query times, shape (M,).
        rtol, atol: local error tolerances of the adaptive method (B-spline potentials).
        full_output: also return a dict with ``"energy_error"`` (max over t of
            ``|p²/2 + V(q) - V0|``, per potential) and ``"steps"`` (accepted steps, -1 if
            ``max_steps`` was exhausted; for scipy's DOP853, its function evaluations).
        max_steps: step budget per potential.

    Returns:
        (q, p), or (q, p, info) with ``full_output``; shapes as in :func:`integrate`.
    """
    t = _check_times(t)
    order = np.argsort(t, kind="stable")
    ts = np.ascontiguousarray(t[order])
    if isinstance(potential, BoundedPotential):
        n = potential.params.shape[0]
        oq, op, ov = (np.empty((n, ts.size)) for _ in range(3))
        steps = np.empty(n, dtype=np.int64)
        _kernels.batch_dp5(potential.params, ts, rtol, atol, max_steps, oq, op, ov, steps)
        energy = np.max(np.abs(ov - V0), axis=1)
    elif hasattr(potential, "dV"):
        sol = sp_integrate.solve_ivp(
            lambda _, y: (y[1], -float(potential.dV(y[0]))), (0.0, max(ts[-1], 1e-300)),
            (0.0, 0.0), method="DOP853", t_eval=ts, rtol=1e-13, atol=1e-13,
        )
        if not sol.success:
            raise RuntimeError(f"reference solve failed: {sol.message}")
        oq, op = sol.y[0][None, :], sol.y[1][None, :]
        energy = np.max(np.abs(0.5 * op**2 + potential.V(oq) - V0), axis=1)
        steps = np.array([sol.nfev])
    else:
        raise TypeError("potential must be a BoundedPotential or have a dV(q) method")
    q = np.empty_like(oq)
    p = np.empty_like(op)
    q[:, order] = oq
    p[:, order] = op
    single = not (isinstance(potential, BoundedPotential) and potential.batched)
    if single:
        q, p, energy, steps = q[0], p[0], energy[0], steps[0]
    if full_output:
        return q, p, {"energy_error": energy, "steps": steps}
    return q, p
