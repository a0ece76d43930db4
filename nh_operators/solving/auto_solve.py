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

import functools
import json
import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from .._constants import SENSORS, TIMES
from ..solvers import ORDERS, adaptive_solve, coerce_potential
from .catalog import (CALIBRATION, WEIGHTS, available_pretrained, network_domain, reads_state,
                      resolve_pretrained)
from .costs import _classical_seconds, _horizon_key, _input_kind, _neural_seconds
from .acceptance import EARLY_HORIZON, acceptance_rate, calibrated, cautious_acceptance_rate
from .estimate import estimate_at, sensor_force

__all__ = ["Solution", "solve", "DEFAULT_TOL"]

#: Tolerance of the classical solve when none is given.
DEFAULT_TOL = 1e-8
#: A network is a candidate only when its expected cost is below this share of the
#: classical one: the costs are calibrated medians, and a near tie saves nothing while a
#: rejected estimate pays twice (a network expected 0.5 % cheaper made ``auto`` dearer at
#: tol 1e-3 on Algorithm-1 potentials, ``benchmarks/promise/solve_contract.py``).
SAVING = 0.9


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
    tol: float = None
    reason: str = ""
    tried: list = field(default_factory=list)


#: Shipped models loaded so far (by name), each with its ``calibration``.
_LOADED = {}


@functools.lru_cache(maxsize=None)
def _calibration_file(name):
    path = WEIGHTS / name / CALIBRATION
    return json.loads(path.read_text()) if path.is_file() else None


def _calibration(name):
    """A shipped model's calibration, or None: the loaded model's, else read from its file
    (so ranking the networks loads neither torch nor a network)."""
    model = _LOADED.get(name)
    return model.calibration if model is not None else _calibration_file(name)


def _model(name):
    """The shipped model ``name``, loaded once, with its ``calibration``."""
    if name not in _LOADED:
        from .shipped import pretrained

        model = pretrained(name)
        model.calibration = _calibration_file(name)
        _LOADED[name] = model
    return _LOADED[name]


def _sensor_values(pot, information):
    return np.asarray(pot if information == "sensors" else pot.V(SENSORS), dtype=np.float64)


def _rows(fn):
    return lambda x: np.asarray(fn(x.reshape(-1)), dtype=np.float64).reshape(x.shape)


def neural_solve(name, pot, information, t, q0=0.0, p0=0.0):
    """Predict with shipped model ``name`` on :data:`TIMES`, estimate, interpolate to t
    (from the state (q0, p0): a network that :func:`reads_state`).

    Returns:
        (q, p, estimate): the estimate is the calibrated one, or the raw estimate when the
        model has no calibration.
    """
    from .._backend import single_threaded

    _model(name)  # loads torch first, so that the block below limits its threads too
    with single_threaded():
        q, p, raw = neural_raw(name, pot, information, t, q0, p0)
        kind = "sensors" if information == "sensors" else "exact"
        early = float(np.max(t)) <= EARLY_HORIZON
        return q, p, float(calibrated(raw, _model(name).calibration, kind, early))


def network_input(name, V, q0=0.0, p0=0.0):
    """The input rows of shipped model ``name``: the sensor values V (N, 100), then
    (q0, p0) (scalars or (N,)) for a network that :func:`reads_state`."""
    if not reads_state(name):
        return V
    n = len(V)
    return np.column_stack([V, np.broadcast_to(q0, (n,)), np.broadcast_to(p0, (n,))])


def neural_raw(name, pot, information, t=TIMES, q0=0.0, p0=0.0):
    """Model ``name``'s prediction at the times ``t`` (the spline through its prediction
    on :data:`TIMES`) from (q0, p0), and its uncalibrated estimate there
    (:func:`~nh_operators.solving.estimate.estimate_at`): (q, p, raw), q and p (M,)."""
    from ..models import predict

    V = _sensor_values(pot, information)
    q, p = predict(_model(name).net, network_input(name, V[None], q0, p0), TIMES,
                   batch_size=1)
    if information == "sensors":
        force = sensor_force(V)
    else:
        force = (_rows(pot.V), _rows(pot.dV))
    qa, pa, raw = estimate_at(q, p, *force, np.asarray(t, dtype=np.float64).reshape(-1),
                              q0=q0, p0=p0)
    raw = float(raw[0])
    return qa[0], pa[0], (raw if np.isfinite(raw) else np.inf)  # inf: far outside [0, 1]


@functools.lru_cache(maxsize=256)
def _ranked(tol, kind, calibrations, batched=False, states=False, horizon=None):
    """(candidates, notes) for ``tol`` and a kind of input (:data:`.costs._TIMINGS`): the
    networks expected to be cheaper than the classical solve, as (name, expected
    seconds, share) cheapest first; cached per tolerance, kind and calibration
    (``calibrations``: ids, so a new one is seen). ``batched``: compare the per-row
    costs inside ``solve_many`` (a network's batched forward and estimate against the
    batched classical solve) instead of one call's. ``states``: the networks that read
    a starting state (:func:`reads_state`, for states other than (0, 0)), else the
    others. ``horizon``: the latest asked time (:func:`_horizon_key`), which the
    classical cost depends on (:func:`_classical_seconds`)."""
    candidates, notes = [], []
    for name in _networks():
        if reads_state(name) != states:
            continue
        cal = _calibration(name)
        if cal is None:
            notes.append(f"{name}: not calibrated")
            continue
        # one call counts on the share it would get from either generator; a batch
        # learns the share on its own rows from a pilot (solve_many)
        exact = "sensors" if kind == "sensors" else "exact"
        share = (acceptance_rate(cal, tol, kind=exact) if batched
                 else cautious_acceptance_rate(cal, tol, exact))
        t_cls = _classical_seconds(cal, tol, kind, batched, horizon)
        expected = _neural_seconds(cal, batched) + (1.0 - share) * t_cls
        if expected >= SAVING * t_cls:
            notes.append(f"{name}: meets tol on {share:.0%} of its calibration set, "
                         f"expected {1e6 * expected:.0f} µs against {1e6 * t_cls:.0f} µs "
                         f"(a network must be expected to save {1 - SAVING:.0%})")
        else:
            candidates.append((name, expected, share))
    return tuple(sorted(candidates, key=lambda c: c[1])), notes


@functools.lru_cache(maxsize=1)
def _networks():
    return tuple(available_pretrained())


def _choose(tol, values, t, kind, states=False):
    """The network to try, or None, with the reason in words: the cheapest candidate
    whose domain (:func:`~nh_operators.solving.catalog.network_domain`) holds the input.
    One call tries one network: going on to the next after a rejection cost more than it
    saved on ``alg1-test`` at tol 1e-4 (an input one network rejects is often rejected
    again, and a single call has no pilot to tell); ``solve_many``, which learns each
    network's share on its rows from a pilot, goes on to the next.
    ``values()`` gives the sensor values; the costs are weighed first, as they need no
    evaluation of V. ``states``: choose among the networks that read a starting state."""
    from ..potentials import domain_violations, in_domain

    candidates, notes = _ranked(tol, kind, tuple(id(_calibration(n)) for n in _networks()),
                                False, states, _horizon_key(t))
    if not candidates:
        what = "reading a starting state " if states else ""
        return None, (f"no network {what}expected to be cheaper ("
                      + ("; ".join(notes) or "none calibrated") + ")")
    if t.min() < 0 or t.max() > TIMES[-1] + 1e-12:
        return None, "times outside [0, 2], where the networks were trained"
    V = values()
    for name, _, share in candidates:
        if in_domain(V, network_domain(name)):
            return name, (f"{name} expected cheapest on its domain: its estimate met tol "
                          f"on {share:.0%} of its calibration set")
    first = candidates[0][0]
    return None, (f"outside the domain of every network expected to be cheaper, e.g. "
                  f"{first}'s: {domain_violations(V, network_domain(first))[0]}")


def solve(potential, t, *, tol=None, method="auto", dV=None, q0=0.0, p0=0.0):
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

    Example:
        >>> sol = solve("sho", [0.5, 1.0], tol=1e-6)
        >>> sol.kind, bool(sol.error_estimate <= 1e-6), round(float(sol.q[1]), 4)
        ('classical', True, 0.8268)
    """
    from .._backend import single_threaded

    start = time.perf_counter()
    with single_threaded():  # one potential: threads only wait for time slices
        return _solve(potential, t, tol, method, dV, start, q0, p0)


def _method_name(method):
    """A method name, or the shipped name of an object from :func:`pretrained`."""
    if isinstance(method, str):
        return method
    shipped = getattr(method, "shipped", None)
    if isinstance(shipped, str):
        return shipped
    raise ValueError(f"solve cannot use {method!r} as its method: its error estimate needs "
                     "a calibrated network, so give a shipped model's name or "
                     "nh.pretrained(NAME); call your own network directly (method(V, t) or "
                     "nh.predict(net, V, t))")


def _rest_at_zero(q0, p0):
    """Whether (q0, p0) is the networks' state (0, 0) (scalars only)."""
    return np.ndim(q0) == 0 and np.ndim(p0) == 0 and float(q0) == 0.0 and float(p0) == 0.0


def _checked(method, tol):
    """(method name, shipped networks, classical names -> integrator), or a clear error."""
    method = _method_name(method)
    if tol is not None and not (isinstance(tol, (int, float)) and np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a positive number or None, got {tol!r}")
    networks = _networks()
    classical = {"classical": "rk4", **{m: m for m in ORDERS}}
    if method != "auto" and method not in classical and method not in networks:
        try:
            method = resolve_pretrained(method)  # "traonet" means "traonet-alg1"
        except ValueError:
            pass
    if method != "auto" and method not in classical and method not in networks:
        raise ValueError(f"unknown method {method!r}; choose 'auto', 'classical', an "
                         f"integrator {sorted(ORDERS)} or a shipped model {list(networks)}")
    return method, networks, classical


def _solve(potential, t, tol, method, dV, start, q0=0.0, p0=0.0):
    method, networks, classical = _checked(method, tol)
    pot, information = coerce_potential(potential, dV)
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    if t.size == 0 or not np.all(np.isfinite(t)) or t.min() < 0:
        raise ValueError("t must be a non-empty array of finite times ≥ 0")
    tried = []

    rest = _rest_at_zero(q0, p0)
    if method in networks:
        if not rest and not reads_state(method):
            raise ValueError(f"{method} was trained from the state (0, 0) only; got (q0, p0) "
                             f"= ({q0}, {p0}): use method='auto', 'classical' or a network "
                             f"that reads a state ({_state_networks() or 'none shipped'})")
        return _forced_network(method, pot, information, t, tol, start, q0, p0)
    if method == "auto" and tol is not None:
        name, reason = _choose(tol, lambda: _sensor_values(pot, information), t,
                               _input_kind(pot, information), states=not rest)
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
    integrator = classical.get(method, "rk4")
    t0 = time.perf_counter()
    sol = adaptive_solve(pot, information, t, DEFAULT_TOL if tol is None else tol, integrator,
                         q0=q0, p0=p0)
    tried.append({"method": integrator, "error_estimate": sol.error_estimate,
                  "accepted": True, "seconds": time.perf_counter() - t0,
                  "substeps": sol.substeps, "period": sol.period})
    return Solution(sol.q, sol.p, integrator, "classical", sol.error_estimate,
                    time.perf_counter() - start, tol, reason, tried)


def _state_networks():
    return [n for n in _networks() if reads_state(n)]


def _forced_network(name, pot, information, t, tol, start, q0=0.0, p0=0.0):
    from ..potentials import OutOfDomainWarning, domain_violations

    if t.max() > TIMES[-1] + 1e-12:
        raise ValueError(f"{name} predicts on t ∈ [0, 2]; got t up to {t.max():g}")
    for message in domain_violations(_sensor_values(pot, information), network_domain(name)):
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
