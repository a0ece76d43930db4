"""Fixed-step solvers of q' = p, p' = -V'(q) from (q0, p0) (default: rest at q = 0), in float64.

- :func:`integrate`: fixed-step RK4 and symplectic methods on a potential known exactly.
- :func:`integrate_sensors`: the same methods on the information a neural operator has,
  V at the 100 :data:`SENSORS`, the force from a spline of the sensors.
- :func:`paper_rk4`: the paper's RK4 row, rebuilt correctly (one RK4 step per output
  interval, force from a PCHIP interpolant) so that it can be shown for what it is.

The truth, :func:`~nh_operators.solvers.reference_solve`, lives in :mod:`.reference`.
The fixed-step solvers warn with :class:`ResolutionWarning` when the step is too coarse
for the potential's curvature (:data:`RESOLUTION_FRACTION`), when the energy has drifted
by :data:`ENERGY_DRIFT_TOL` at the last query time (sensor splines and formulas), or when
a formula's force jumps (a kink: fixed steps are then first order).
"""

import numpy as np

from .._constants import SENSORS, TIMES, V0
from .._sensors import sensor_values
from ..potentials._spline_kernels import bspline_force, bspline_value, grid_force, grid_value
from ..potentials.bounded import BoundedPotential, check_bounded
from ._kernels import batch_fixed, notaknot_params, trajectory_fixed
from ._rowwise import pairwise
from .resolution import (
    check_energy,
    check_formula,
    check_resolution_of,
    spline_curvature,
    spline_drift,
)
from .schemes import check_times, step_grid, step_method
from .states import check_states, state_arrays

__all__ = ["integrate", "integrate_sensors", "paper_rk4", "sensor_spline_params"]


def _states(q0, p0, n, value, params, batched):
    """Checked (q0s, p0s, energies) of n rows whose V is ``value(params[i], x)``."""
    q0s, p0s = state_arrays(q0, p0, n)

    def value_at(x):
        out = np.empty(n)
        pairwise(value, params, np.ascontiguousarray(x), out)
        return out

    return q0s, p0s, check_states(q0s, p0s, value_at, batched)


def _run_fixed(force, params, t, method, substeps, interval, q0s, p0s):
    rk4, weights = step_method(method)
    order, ts, h, nsteps = step_grid(t, substeps, interval)
    n = params.shape[0]
    oq = np.empty((n, ts.size))
    op = np.empty((n, ts.size))
    batch_fixed(force, params, ts, h, nsteps, rk4, weights, oq, op, q0s, p0s)
    q = np.empty_like(oq)
    p = np.empty_like(op)
    q[:, order] = oq
    p[:, order] = op
    return q, p


def integrate(potential, t=TIMES, method="rk4", substeps=1, *, interval=None,
              check_resolution=True, q0=0.0, p0=0.0):
    """Integrate Hamilton's equations with a fixed-step method on an exact potential.

    The particle starts from (q0, p0) at t = 0 (default: at rest at q = 0).
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
        q0, p0: starting state, scalars or (N,) for a batch; the energy
            p0²/2 + V(q0) must be ≤ V0 and q0 in [0, 1].

    Returns:
        (q, p): float64 arrays of shape (M,) for one potential, (N, M) for a batch.

    Raises:
        ValueError: for an unknown method, bad times or substeps, a state that would
            leave [0, 1], or more than :data:`~nh_operators.solvers.schemes.MAX_STEPS`
            steps.
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
    t = check_times(t)
    if isinstance(potential, BoundedPotential):
        q0s, p0s, _ = _states(q0, p0, potential.params.shape[0], bspline_value,
                              potential.params, potential.batched)
        q, p = _run_fixed(bspline_force, potential.params, t, method, substeps,
                          interval, q0s, p0s)
        if check_resolution:
            curvature = np.abs(potential.d2V(SENSORS)).reshape(-1, SENSORS.size).max(axis=1)
            check_resolution_of(curvature, t, method, substeps, interval, potential.batched)
        return (q, p) if potential.batched else (q[0], p[0])
    if isinstance(potential, (list, tuple)):
        q0s, p0s = state_arrays(q0, p0, len(potential))  # one state per potential
        pairs = [integrate(pot, t, method, substeps, interval=interval,
                           check_resolution=check_resolution, q0=a, p0=b)
                 for pot, a, b in zip(potential, q0s, p0s, strict=True)]
        return np.stack([a for a, _ in pairs]), np.stack([b for _, b in pairs])
    if not hasattr(potential, "dV"):
        raise TypeError(
            "potential must be a BoundedPotential or have a vectorised dV(q) method; for "
            "values at the sensors use integrate_sensors"
        )
    q0s, p0s = state_arrays(q0, p0, 1)
    energy = check_states(q0s, p0s, lambda x: potential.V(x) if hasattr(potential, "V")
                          else V0 - 0.5 * p0s**2)[0]
    if check_resolution:
        check_formula(potential, t, method, substeps, interval)
    rk4, weights = step_method(method)
    order, ts, h, nsteps = step_grid(t, substeps, interval)
    oq = np.empty(ts.size)
    op = np.empty(ts.size)

    def force(_params, x):
        return -float(potential.dV(x))

    trajectory_fixed.py_func(force, None, ts, h, nsteps, rk4, weights, oq, op,
                             q0s[0], p0s[0])
    q = np.empty_like(oq)
    p = np.empty_like(op)
    q[order] = oq
    p[order] = op
    if check_resolution and hasattr(potential, "V"):
        with np.errstate(all="ignore"):
            drift = abs(0.5 * op[-1] ** 2 + float(potential.V(oq[-1])) - energy)
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
        notaknot_params(V, out)
        return out
    if interpolation == "pchip":
        from scipy.interpolate import PchipInterpolator  # only here: a slow import

        spline = PchipInterpolator(SENSORS, V, axis=1)
    else:
        raise ValueError(f"interpolation must be 'cubic' or 'pchip', got {interpolation!r}")
    return _piece_coefficients(spline.c)


def integrate_sensors(V, t=TIMES, method="rk4", substeps=1, interpolation="cubic", *,
                      interval=None, check_resolution=True, q0=0.0, p0=0.0):
    """Integrate with the force from a spline of the sensor values: the honest baseline.

    A neural operator sees V only at the 100 :data:`SENSORS`; this solver uses the same
    information. With ``interpolation="cubic"`` the force is -V' of the not-a-knot cubic
    spline of the sensors; ``"pchip"`` uses the shape-preserving PCHIP interpolant.

    Args:
        V: sensor values, shape (100,) or (N, 100), or a potential with ``V(q)`` (sampled
            at the sensors); checked with :func:`check_bounded`.
        t, method, substeps, interval: as in :func:`integrate`.
        interpolation: ``"cubic"`` or ``"pchip"``.
        check_resolution: warn when the step is too coarse (negligible cost).
        q0, p0: starting state, scalars or (N,); the energy p0²/2 + V(q0) on the
            spline must be ≤ V0 and q0 in [0, 1].

    Returns:
        (q, p) of shape (M,) or (N, M).

    Raises:
        ValueError: if V breaks the bounded conditions or has the wrong shape, for a
            state that would leave [0, 1], or more than
            :data:`~nh_operators.solvers.schemes.MAX_STEPS` steps.

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
    t = check_times(t)
    V = check_bounded(sensor_values(V))
    single = V.ndim == 1
    params = sensor_spline_params(np.atleast_2d(V), interpolation)
    q0s, p0s, energy = _states(q0, p0, params.shape[0], grid_value, params,
                               not single)
    if check_resolution:
        check_resolution_of(spline_curvature(params), t, method, substeps, interval, not single)
    q, p = _run_fixed(grid_force, params, t, method, substeps, interval,
                      q0s, p0s)
    if check_resolution:
        last = int(np.argmax(t))
        check_energy(spline_drift(params, q[:, last], p[:, last], energy), t, method,
                      substeps, interpolation, not single)
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
