"""``solve(potential, t, tol=..., method="auto")``: a network when it is expected to be
cheaper and its estimate meets the tolerance, the classical solver otherwise.

How ``method="auto"`` chooses, for a tolerance ``tol`` on L_tot:

1. Without ``tol``: the classical solver at :data:`DEFAULT_TOL`.
2. A shipped network is a candidate when it has a calibration
   (``weights/NAME/calibration.json``, :func:`calibrate_pretrained`), the input is in
   its domain (the sensor values inside the bounds of its own training rows,
   ``weights/NAME/domain.json``, else the generator's:
   :func:`~nh_operators.domain_violations`; the times inside [0, 2]), and it is expected
   to be cheaper: with P the share of its calibration set whose calibrated estimate met
   ``tol`` (the smaller of that share on its own distribution and on the other
   generator's potentials inside its domain: a single call cannot tell which generator
   its input came from), and the median times measured at calibration,
   T_net + (1 − P)·T_classical <
   T_classical(tol), where T_classical is the one for this kind of input (a generator
   B-spline, sensor values, or a formula, which the solver integrates in Python).
3. The cheapest candidate predicts on :data:`TIMES`, interpolated to ``t`` by cubic
   splines; its estimate is the calibrated raw one, raw being the Picard defect carried
   through the linearised flow to the asked times
   (:mod:`nh_operators.solving.estimate`). At or below ``tol`` that prediction is
   returned; otherwise the classical solver runs, and the record lists both attempts.

The classical solver (:func:`~nh_operators.solve_classical`) doubles RK4 substeps until
its own estimate is met; it computes exactly the requested times.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._constants import TIMES
from ..solvers import adaptive_solve, coerce_potential
from .kinds import InputKind
from .loader import load
from .network_pass import neural_solve, sensor_values
from .ranking import CLASSICAL, DEFAULT_TOL, check_method, choose

__all__ = ["DEFAULT_TOL", "Solution", "solve"]


@dataclass
class Solution:
    """What :func:`solve` returns.

    Attributes:
        q, p: float64 arrays (M,) at the requested times, in their order.
        method: the method that produced them (``"rk4"``, ``"deeponet"``, ...).
        kind: ``"classical"`` or ``"neural"``.
        error_estimate: estimated L_tot of (q, p) against the true trajectory.
        seconds: wall time of the whole call.
        tol: the tolerance asked for (``None`` if none).
        reason: why this method was used, in words.
        tried: one dict per method run (method, error_estimate, seconds, accepted).
    """

    q: np.ndarray
    p: np.ndarray
    method: str
    kind: str
    error_estimate: float
    seconds: float
    tol: float | None = None
    reason: str = ""
    tried: list[dict[str, Any]] = field(default_factory=list)


def solve(potential: Any, t: Any, *, tol: float | None = None, method: Any = "auto",
          dV: Any = None, q0: float = 0.0, p0: float = 0.0) -> Solution:
    """The trajectory at exactly the times ``t``, by the cheapest method expected to meet
    ``tol``, from the state (q0, p0).

    Any horizon costs about one period of the orbit: times beyond 2 are answered from
    the period (:mod:`nh_operators.solvers.periodic`), and the estimate includes the
    phase error of the period. The networks answer t ∈ [0, 2]: from (0, 0) the ones
    trained at rest, from another state the ones that read a starting state
    (:func:`~nh_operators.solving.reads_state`); later times are solved classically.

    Args:
        potential: a name of :data:`~nh_operators.PHYSICAL_POTENTIALS`, a text
            expression in q, a callable V(q) (with ``dV``), an object with ``V`` and
            ``dV``, a :class:`~nh_operators.BoundedPotential`, or the 100 sensor values.
        t: query times, shape (M,), ≥ 0 (≤ 2 for a network).
        tol: target L_tot (> 0); ``None``: no target (``auto`` then solves classically
            at :data:`DEFAULT_TOL`).
        method: ``"auto"`` (see the module docstring), ``"classical"`` (RK4), an
            integrator of :data:`~nh_operators.METHODS`, a shipped model of
            :func:`~nh_operators.available_pretrained`, or the object
            :func:`~nh_operators.pretrained` returns for one (its shipped weights and
            calibration are used).
        dV: derivative of a callable ``potential``.
        q0, p0: the starting state (floats, default (0, 0), the paper's); its energy
            p0²/2 + V(q0) must be ≤ V0 and q0 in [0, 1].

    Returns:
        :class:`Solution`.

    Raises:
        ValueError: a bad potential, times, tolerance, state or method name, times
            outside [0, 2] for a network, a state other than (0, 0) for a network that
            does not read one, or a time beyond what float64 resolves.
        PeriodError: a far horizon on an orbit whose period cannot be found (a
            separatrix).

    Warns:
        UserWarning: a forced network whose estimate exceeds ``tol``.
        OutOfDomainWarning: a forced network on an input outside its domain.

    Thread safety: the answer is, the thread counts are not. The call sets torch's and
    numba's process-wide thread counts to 1 and restores them on return, so other
    threads' torch and numba work runs on one thread meanwhile, and overlapping calls
    may restore each other's counts out of order (``docs/solve.md``, "Threads"). The
    only other state kept is :mod:`~nh_operators.solving.loader`'s cache of networks.

    Example:
        >>> sol = solve("sho", [0.5, 1.0], tol=1e-6)
        >>> sol.kind, bool(sol.error_estimate <= 1e-6), round(float(sol.q[1]), 4)
        ('classical', True, 0.8268)
    """
    from .._backend import single_threaded

    start = time.perf_counter()
    with single_threaded():  # one potential: threads only wait for time slices
        return _solve(potential, t, tol, method, dV, start, q0, p0)


def _rest_at_zero(q0, p0):
    """Whether (q0, p0) is the networks' state (0, 0) (scalars only)."""
    return np.ndim(q0) == 0 and np.ndim(p0) == 0 and float(q0) == 0.0 and float(p0) == 0.0


def _solve(potential, t, tol, method, dV, start, q0=0.0, p0=0.0):
    method, networks = check_method(method, tol)
    pot, information = coerce_potential(potential, dV)
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    if t.size == 0 or not np.all(np.isfinite(t)) or t.min() < 0:
        raise ValueError("t must be a non-empty array of finite times ≥ 0")
    tried = []

    rest = _rest_at_zero(q0, p0)
    if method in networks:
        if not rest and not load(method).reads_state:
            raise ValueError(f"{method} was trained from the state (0, 0) only; got (q0, p0) "
                             f"= ({q0}, {p0}): use method='auto', 'classical' or a network "
                             f"that reads a state ({_state_networks() or 'none shipped'})")
        return _forced_network(method, pot, information, t, tol, start, q0, p0)
    if method == "auto" and tol is not None:
        name, reason = choose(tol, lambda: sensor_values(pot, information), t,
                              InputKind.of(pot, information), states=not rest)
        if name is not None:
            t0 = time.perf_counter()
            q, p, estimate = neural_solve(name, pot, information, t, q0, p0)
            accepted = estimate <= tol
            tried.append({"method": name, "error_estimate": estimate, "accepted": accepted,
                          "seconds": time.perf_counter() - t0})
            if accepted:
                return Solution(q, p, name, "neural", estimate, time.perf_counter() - start,
                                tol, reason, tried)
            reason = f"{name}'s estimate {estimate:.2g} > tol {tol:g}; classical instead"
    elif method == "auto":
        reason = f"no tol: the classical solver at {DEFAULT_TOL:g}"
    else:
        reason = "forced"
    integrator = CLASSICAL.get(method, "rk4")
    t0 = time.perf_counter()
    sol = adaptive_solve(pot, information, t, DEFAULT_TOL if tol is None else tol, integrator,
                         q0=q0, p0=p0)
    tried.append({"method": integrator, "error_estimate": sol.error_estimate,
                  "accepted": True, "seconds": time.perf_counter() - t0,
                  "substeps": sol.substeps, "period": sol.period})
    return Solution(sol.q, sol.p, integrator, "classical", sol.error_estimate,
                    time.perf_counter() - start, tol, reason, tried)


def _state_networks() -> list[str]:
    from .catalog import shipped_names

    return [n for n in shipped_names() if load(n).reads_state]


def _forced_network(name, pot, information, t, tol, start, q0=0.0, p0=0.0):
    from ..potentials import OutOfDomainWarning, domain_violations

    if t.max() > TIMES[-1] + 1e-12:
        raise ValueError(f"{name} predicts on t ∈ [0, 2]; got t up to {t.max():g}")
    for message in domain_violations(sensor_values(pot, information), load(name).domain):
        warnings.warn(f"{name}: {message}", OutOfDomainWarning, stacklevel=4)
    q, p, estimate = neural_solve(name, pot, information, t, q0, p0)
    if tol is not None and estimate > tol:
        warnings.warn(f"{name}'s error estimate {estimate:.2g} exceeds tol {tol:g}; use "
                      "method='auto' to fall back to the classical solver", UserWarning,
                      stacklevel=4)
    seconds = time.perf_counter() - start
    return Solution(q, p, name, "neural", estimate, seconds, tol, "forced",
                    [{"method": name, "error_estimate": estimate, "accepted": True,
                      "seconds": seconds}])
