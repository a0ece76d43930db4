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
its own estimate is met, up to :data:`~nh_operators.solving.answers.MAX_SUBSTEPS`; it
computes exactly the requested times.

What an answer promises (:mod:`~nh_operators.solving.answers`): ``converged=True`` means
its estimate met tol, measured against ``truth`` — for certain on the classical path,
at the calibrated quantile (0.999) for a network. A tol the classical solver cannot
reach returns its finest answer with ``converged=False``, the reason in words, and a
``RuntimeWarning``; it never raises for that.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._constants import TIMES
from ..solvers import adaptive_solve, coerce_potential
from .answers import MAX_SUBSTEPS, Candidate, Truth, Verdict, candidates, truth_of
from .costs import horizon_key
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
        error_estimate: estimated L_tot of (q, p) against ``truth``.
        converged: whether ``error_estimate`` ≤ tol (:data:`DEFAULT_TOL` when ``tol`` is
            None). False comes with a ``reason`` that says so and, where a tol was
            given or the classical solver ran, a ``RuntimeWarning`` (classical) or
            ``UserWarning`` (a forced network).
        truth: what the estimate is measured against: ``truth.reference`` is the exact
            potential or the sensor spline (for sensor values: the spline through them,
            not any potential they were sampled from); ``truth.confidence`` is 1.0 on the
            classical path and a network's calibrated quantile (0.999) otherwise.
        seconds: wall time of the whole call.
        tol: the tolerance asked for (``None`` if none).
        reason: why this method was used, one short sentence.
        tried: one dict per method run (method, error_estimate, seconds, accepted).
        candidates: with ``method="auto"`` and a tol, every shipped network weighed,
            with its verdict, share and costs (:class:`~.answers.Candidate`); else ().
    """

    q: np.ndarray
    p: np.ndarray
    method: str
    kind: str
    error_estimate: float
    converged: bool
    truth: Truth
    seconds: float
    tol: float | None = None
    reason: str = ""
    tried: list[dict[str, Any]] = field(default_factory=list)
    candidates: tuple[Candidate, ...] = ()


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
        t: query times, shape (M,) (or a scalar), ≥ 0 (≤ 2 for a network); 2-D times
            are refused (several rows of times: :func:`~nh_operators.solve_many`).
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
        :class:`Solution`. The promise: with ``converged=True`` the estimate is ≤ tol
        against ``truth`` — certain on the classical path (``truth.confidence`` 1.0); a
        network's estimate bounds its calibrated quantile (0.999) of the true error, so
        about 1 in 1,000 accepted network answers may exceed tol. For sensor values
        the truth is the sensors' spline (``truth.reference`` ``"sensor spline"``), which
        can be far from a potential they were sampled from. A tol the classical solver
        cannot reach within :data:`~nh_operators.solving.answers.MAX_SUBSTEPS` (a kink,
        as MFF's, at tol 1e-12) returns its finest answer with ``converged=False``.

    Raises:
        ValueError: a bad potential, times (2-D ones included), tolerance, state or
            method name, times outside [0, 2] for a network, a state other than (0, 0)
            for a network that does not read one, or a time beyond what float64
            resolves.
        PeriodError: a far horizon on an orbit whose period cannot be found (a
            separatrix).

    Warns:
        RuntimeWarning: tol not reached by the classical solver (``converged=False``).
        UserWarning: a forced network whose estimate exceeds ``tol`` (``converged=False``).
        OutOfDomainWarning: a forced network on an input outside its domain.

    Thread safety: the answer is, the thread counts are not. The call sets torch's and
    numba's process-wide thread counts to 1 and restores them on return, so other
    threads' torch and numba work runs on one thread meanwhile, and overlapping calls
    may restore each other's counts out of order (``docs/solve.md``, "Threads"). The
    only other state kept is :mod:`~nh_operators.solving.loader`'s cache of networks.

    Example:
        >>> sol = solve("sho", [0.5, 1.0], tol=1e-6)
        >>> sol.kind, sol.converged, str(sol.truth), round(float(sol.q[1]), 4)
        ('classical', True, 'exact potential', 0.8268)
    """
    from .._backend import single_threaded

    start = time.perf_counter()
    with single_threaded():  # one potential: threads only wait for time slices
        return _solve(potential, t, tol, method, dV, start, q0, p0)


def _rest_at_zero(q0, p0):
    """Whether (q0, p0) is the networks' state (0, 0) (scalars only)."""
    if type(q0) is float and type(p0) is float:  # the usual case, without numpy
        return q0 == 0.0 and p0 == 0.0
    return np.ndim(q0) == 0 and np.ndim(p0) == 0 and float(q0) == 0.0 and float(p0) == 0.0


def _times(t: Any) -> np.ndarray:
    """The asked times as (M,) float64, or a clear error (2-D times are refused)."""
    t = np.asarray(t, dtype=np.float64)
    if t.ndim > 1:
        raise ValueError(f"t must be one-dimensional, shape (M,); got shape {t.shape} (for "
                         "several rows of times use nh.solve_many)")
    t = t.reshape(-1)
    if t.size == 0 or not np.all(np.isfinite(t)) or t.min() < 0:
        raise ValueError("t must be a non-empty array of finite times ≥ 0")
    return t


def _solve(potential, t, tol, method, dV, start, q0=0.0, p0=0.0):
    method, networks = check_method(method, tol)
    pot, information = coerce_potential(potential, dV)
    t = _times(t)
    tried = []
    kind = InputKind.of(pot, information)
    weighed: tuple[Candidate, ...] = ()

    rest = _rest_at_zero(q0, p0)
    if method in networks:
        if not rest and not load(method).reads_state:
            raise ValueError(f"{method} was trained from the state (0, 0) only; got (q0, p0) "
                             f"= ({q0}, {p0}): use method='auto', 'classical' or a network "
                             f"that reads a state ({_state_networks() or 'none shipped'})")
        return _forced_network(method, pot, information, t, tol, start, q0, p0)
    if method == "auto" and tol is not None:
        name, reason = choose(tol, lambda: sensor_values(pot, information), t, kind,
                              states=not rest)
        accepted = None
        if name is not None:
            t0 = time.perf_counter()
            q, p, estimate = neural_solve(name, pot, information, t, q0, p0)
            accepted = bool(estimate <= tol)
            tried.append({"method": name, "error_estimate": estimate, "accepted": accepted,
                          "seconds": time.perf_counter() - t0})
        weighed = candidates(tol, kind, not rest, horizon_key(t), t, name, accepted)
        if name is not None and accepted:
            return Solution(q, p, name, "neural", estimate, True, truth_of(kind, name),
                            time.perf_counter() - start, tol,
                            f"{name} was expected cheapest and its estimate met tol",
                            tried, weighed)
        reason = _classical_reason(name, reason, weighed, tried, tol)
    elif method == "auto":
        reason = f"no tol: the classical solver at {DEFAULT_TOL:g}"
    else:
        reason = "forced"
    integrator = CLASSICAL.get(method, "rk4")
    target = DEFAULT_TOL if tol is None else tol
    t0 = time.perf_counter()
    sol = adaptive_solve(pot, information, t, target, integrator, MAX_SUBSTEPS,
                         q0=q0, p0=p0)
    converged = bool(sol.error_estimate <= target)
    tried.append({"method": integrator, "error_estimate": sol.error_estimate,
                  "accepted": True, "seconds": time.perf_counter() - t0,
                  "substeps": sol.substeps, "period": sol.period})
    if not converged:
        reason = (f"{reason}; not converged: the classical estimate {sol.error_estimate:.2g} "
                  f"missed tol {target:g} at {sol.substeps} substeps")
    return Solution(sol.q, sol.p, integrator, "classical", sol.error_estimate, converged,
                    truth_of(kind), time.perf_counter() - start, tol, reason, tried, weighed)


def _classical_reason(name: str | None, reason: str, weighed: tuple[Candidate, ...],
                      tried: list[dict[str, Any]], tol: float) -> str:
    """Why ``auto`` with a tol solved classically, in one short clause (the details are
    in ``weighed``)."""
    if name is not None:
        return (f"{name}'s estimate {tried[0]['error_estimate']:.2g} > tol {tol:g}: "
                "the classical solver instead")
    verdicts = {c.verdict for c in weighed}
    if Verdict.OUTSIDE_TIMES in verdicts:
        return "times outside [0, 2], where the networks were trained: the classical solver"
    if Verdict.OUTSIDE_DOMAIN in verdicts:
        return ("input outside the domain of every network expected to be cheaper: "
                "the classical solver")
    return reason.split(" (", 1)[0] + ": the classical solver (see candidates)"


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
    converged = bool(estimate <= (DEFAULT_TOL if tol is None else tol))
    reason = "forced"
    if tol is not None and not converged:
        warnings.warn(f"{name}'s error estimate {estimate:.2g} exceeds tol {tol:g}; use "
                      "method='auto' to fall back to the classical solver", UserWarning,
                      stacklevel=4)
        reason = f"forced; not converged: its estimate {estimate:.2g} > tol {tol:g}"
    seconds = time.perf_counter() - start
    return Solution(q, p, name, "neural", estimate, converged,
                    truth_of(InputKind.of(pot, information), name), seconds, tol, reason,
                    [{"method": name, "error_estimate": estimate, "accepted": True,
                      "seconds": seconds}])
