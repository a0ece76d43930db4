"""The truth: an adaptive high-accuracy solve of a B-spline potential or a formula.

A B-spline curve is solved in its curve parameter by compiled Dormand–Prince 5(4)
(:mod:`._curve_kernels`) at ``rtol = atol = 1e-15``, landing on every query time; a
formula by SciPy's DOP853 at 1e-13. Why a separate solver: the labels of every dataset
and the errors of every method are measured against it, so it must be far more accurate
than anything it judges, whatever it costs.
"""

import numpy as np

from .._constants import TIMES
from ..potentials.bounded import BoundedPotential
from ._curve_kernels import batch_dp5, curve_starts
from .schemes import check_times
from .states import check_states, state_arrays

__all__ = ["reference_solve"]


def reference_solve(potential, t=TIMES, *, q0=0.0, p0=0.0, rtol=1e-15, atol=1e-15,
                    full_output=False, max_steps=10_000_000):
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
        q0, p0: the starting state, scalars or one per potential of a batch (default: the
            paper's (0, 0)); its energy must be at most V0 (see
            :func:`~nh_operators.solvers.check_states`). On a B-spline curve the start's
            curve parameter is found by bisection of q(λ) to rounding.
        rtol, atol: local error tolerances of the adaptive method (B-spline potentials).
        full_output: also return a dict with ``"energy_error"`` (max over t of
            ``|p²/2 + V(q) - E|``, per potential, E the starting energy) and ``"steps"``
            (accepted steps, -1 if ``max_steps`` was exhausted; for scipy's DOP853, its
            function evaluations).
        max_steps: step budget per potential.

    Raises:
        ValueError: bad times, or a state outside [0, 1] or above V0.
        TypeError: a potential that is neither.

    Example:
        >>> from nh_operators.potentials import PHYSICAL_POTENTIALS
        >>> sho = PHYSICAL_POTENTIALS["sho"]  # V = 8 (q - 1/2)², ω = 4
        >>> q, p = reference_solve(sho, [0.25], q0=0.5, p0=1.0)  # q = 1/2 + sin(4t)/4
        >>> round(float(q[0]), 10), round(float(0.5 + np.sin(1.0) / 4), 10)
        (0.7103677462, 0.7103677462)
    """
    t = check_times(t)
    order = np.argsort(t, kind="stable")
    ts = np.ascontiguousarray(t[order])
    if isinstance(potential, BoundedPotential):
        n = potential.params.shape[0]
        q0s, p0s = state_arrays(q0, p0, n)
        lam0s, v0s = np.empty(n), np.empty(n)
        curve_starts(potential.params, q0s, lam0s, v0s)
        start = check_states(q0s, p0s, lambda _: v0s, potential.batched)
        oq, op, ov = (np.empty((n, ts.size)) for _ in range(3))
        steps = np.empty(n, dtype=np.int64)
        batch_dp5(potential.params, ts, rtol, atol, max_steps, oq, op, ov, steps,
            lam0s, p0s)
        energy = np.max(np.abs(ov - start[:, None]), axis=1)
    elif hasattr(potential, "dV"):
        q0s, p0s = state_arrays(q0, p0, 1)
        start = check_states(q0s, p0s, lambda x: potential.V(x))
        from scipy import integrate as sp_integrate  # a slow import, only here

        sol = sp_integrate.solve_ivp(
            lambda _, y: (y[1], -float(potential.dV(y[0]))), (0.0, max(ts[-1], 1e-300)),
            (q0s[0], p0s[0]), method="DOP853", t_eval=ts, rtol=1e-13, atol=1e-13,
        )
        if not sol.success:
            raise RuntimeError(f"reference solve failed: {sol.message}")
        oq, op = sol.y[0][None, :], sol.y[1][None, :]
        energy = np.max(np.abs(0.5 * op**2 + potential.V(oq) - start[0]), axis=1)
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
