"""Methods compared side by side: trained networks and classical solvers, one interface.

A *method* maps sensor values V (N, 100) and query times t (M,) to (q, p), each (N, M),
exactly the information a neural operator has. :class:`ClassicalMethod` wraps a solver
on the sensors; :class:`NeuralMethod` wraps a trained network. Evaluation, timing and
the speed/accuracy study (:mod:`nh_operators.evaluation.report`) take any mapping name → method.
"""

import abc
import warnings

import numpy as np
from scipy.integrate import solve_ivp

from .._backend import single_threaded
from .._constants import TIMES
from .._sensors import sensor_spline, sensor_values
from ..solvers import integrate_sensors, paper_rk4

__all__ = ["Method", "ClassicalMethod", "NeuralMethod", "CLASSICAL_METHODS",
           "EVALUATE_BASELINES", "classical_methods", "dop853_sensors"]


class Method(abc.ABC):
    """Abstract: ``method(V, t) -> (q, p)`` with a name, a kind and a device.

    Attributes:
        name: key in tables and reports.
        kind: ``"classical"`` or ``"neural"``.
        family: methods of one family differ by one knob (substeps, tolerance) and are
            joined by a line in the work-precision figure.
        device: where it runs, e.g. ``"cpu"`` or ``"cuda:0"``.
        batched: False when the method solves one trajectory at a time in Python (then
            evaluations may use a subset of a large test set).
    """

    name: str
    kind: str
    family: str
    device: str = "cpu"
    batched: bool = True

    @abc.abstractmethod
    def __call__(self, V, t):
        """Args: V (N, 100) float64 sensor values; t (M,) times. Returns (q, p), (N, M) each."""

    def synchronize(self):  # noqa: B027 (an optional hook: a no-op unless overridden)
        """Wait for queued device work; called around timed sections.

        An optional hook: a no-op here (CPU work is synchronous); a method running on an
        asynchronous device overrides it (:meth:`NeuralMethod.synchronize`).
        """

    def __repr__(self):
        return f"{type(self).__name__}({self.name!r})"


class ClassicalMethod(Method):
    """A classical solver on the sensor values (final).

    Args:
        name: its key.
        run: callable ``(V (N, 100), t (M,)) -> (q, p)``.
        family: see :class:`Method`.
        batched: whether ``run`` handles a batch at once (compiled) or loops in Python.
        description: one line for reports.

    Example:
        >>> import nh_operators as nh
        >>> rk4 = CLASSICAL_METHODS["rk4_sensors_4"]
        >>> q, p = rk4(nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS)[None], nh.TIMES)
        >>> q.shape
        (1, 100)
    """

    kind = "classical"

    def __init__(self, name, run, family, *, batched=True, description=""):
        self.name = name
        self._run = run
        self.family = family
        self.batched = batched
        self.description = description

    def __call__(self, V, t):
        return self._run(sensor_values(V), np.asarray(t, dtype=np.float64))


#: Rows below which a network's call on the CPU runs torch and numba on one thread (as
#: ``solve_many`` does below the same count; :func:`~nh_operators._backend.single_threaded`):
#: at batch 1, at torch's and numba's default 2 threads, a PhaseONet call took
#: 0.66–1.2 ms against 0.4–0.5 ms on one (``benchmarks/cost/api_overhead.py``).
THREADS_FROM = 256


class NeuralMethod(Method):
    """A trained network as a method (final).

    Args:
        net: a network of :data:`nh_operators.MODELS` (or any DeepXDE network with the
            ``(V, t) -> (B, M, 2)`` contract), or another method holding one in ``.net``.
        name: its key (default: the wrapped method's name, else the class name, lower
            case).
        batch_size: potentials per forward pass.
        domain_check: warn (:class:`~nh_operators.potentials.OutOfDomainWarning`) when
            an input lies outside ``domain``, and refuse times beyond the training range
            [0, 2] (times must be finite and ≥ 0 in any case).
        domain: the inputs the network was trained on, as bounds at the sensors
            (:func:`~nh_operators.potentials.fit_domain`; default
            :data:`~nh_operators.potentials.GENERATOR_DOMAIN`). Also the attribute
            ``domain``.

    Example:
        >>> import nh_operators as nh
        >>> m = NeuralMethod(nh.build_model("deeponet", preset="cpu"), "deeponet")
        >>> m.kind, m.device
        ('neural', 'cpu')
    """

    kind = "neural"
    # set by from_run only (declared, not assigned: other methods have no such attribute)
    config: dict
    run_dir: str

    def __init__(self, net, name=None, *, batch_size=1000, domain_check=True, domain=None):
        from ..models import as_network  # here: the classical methods need no torch

        name = name or getattr(net, "name", None)
        net = as_network(net)  # a network, or another method holding one
        self.net = net
        self.name = name or type(net).__name__.lower()
        self.family = self.name
        self.batch_size = batch_size
        self.domain_check = domain_check
        self.domain = domain
        self.device = str(next(net.parameters()).device)

    @classmethod
    def from_run(cls, run_dir, *, device="cpu", name=None, batch_size=1000):
        """Load a run directory written by :func:`nh_operators.train`.

        Args:
            run_dir: the run directory (or its checkpoint file).
            device: ``"cpu"``, ``"cuda"``, ``"cuda:N"``.
            name: key (default: the run's model name, e.g. ``"traonet"``).
            batch_size: potentials per forward pass.

        Returns:
            NeuralMethod with ``config`` (the run's config dict) and ``run_dir`` set.

        Raises:
            FileNotFoundError, ValueError: as :func:`nh_operators.load_model`.
        """
        from ..training import load_model

        net, config = load_model(run_dir, device=device)
        method = cls(net, name or config["model"], batch_size=batch_size)
        method.config = config
        method.run_dir = str(run_dir)
        return method

    def __call__(self, V, t, q0=0.0, p0=0.0):
        """Predict (q, p), each (N, M), for sensor values V (N, 100) at times t, from
        the starting states (q0, p0) (scalars or (N,); default the rest state (0, 0),
        the only one a network without ``initial_state`` knows).

        Below :data:`THREADS_FROM` rows on the CPU the call sets torch's and numba's
        thread counts to 1 and restores them on return, as :func:`nh_operators.solve`
        does (not thread-safe for torch: ``docs/solve.md``, "Threads")."""
        from ..models import predict

        if not (type(V) is np.ndarray and V.dtype == np.float64):
            V = sensor_values(V)  # a float64 array is only read here, and by predict
        t = _network_times(self.name, t, self.domain_check)
        if self.domain_check:
            _warn_out_of_domain(self.name, V, self.domain)
        if getattr(self.net, "initial_state", False):
            rows = np.atleast_2d(V)
            n = len(rows)
            state = [np.broadcast_to(np.asarray(a, dtype=np.float64), (n,)) for a in (q0, p0)]
            stacked = np.column_stack([rows, *state])
            V = stacked[0] if np.ndim(V) == 1 else stacked   # one potential stays one
        elif not _at_rest(q0, p0):
            raise ValueError(f"{self.name} was trained from the state (0, 0) only; a network "
                             "built with initial_state=True reads other states")
        if self.device == "cpu" and (1 if np.ndim(V) == 1 else len(V)) < THREADS_FROM:
            with single_threaded():  # a few rows: threads would only wait for each other
                return predict(self.net, V, t, batch_size=self.batch_size)
        return predict(self.net, V, t, batch_size=self.batch_size)

    def synchronize(self):
        if self.device.startswith("cuda"):
            import torch

            torch.cuda.synchronize(self.device)


def _network_times(name, t, domain_check):
    """Query times a network may be asked: finite, ≥ 0, and in its training range [0, 2]
    (beyond it only when the domain check is off: extrapolation asked for explicitly)."""
    if t is TIMES:  # the grid itself (read-only): it passes every check
        return t
    t = np.asarray(t, dtype=np.float64)
    if t.ndim == 2 and t.shape[1] == 1:
        t = t[:, 0]
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"{name}: t must have shape (M,) or (M, 1) with M ≥ 1, got {t.shape}")
    lo, hi = t.min(), t.max()  # a NaN or an infinity shows in one of them
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo < 0:
        bad = t[~(np.isfinite(t) & (t >= 0))][0]
        raise ValueError(f"{name}: times must be finite and ≥ 0, got {bad}")
    if domain_check and hi > TIMES[-1] + 1e-12:
        raise ValueError(f"{name} was trained on t ∈ [0, {TIMES[-1]:g}] and is not asked "
                         f"beyond it (got t = {hi:g}); use nh.solve for later times, or "
                         "NeuralMethod(..., domain_check=False) to extrapolate")
    return t


def _at_rest(q0: object, p0: object) -> bool:
    """Whether the starting states are all (0, 0); plain numbers without NumPy."""
    if type(q0) in (int, float) and type(p0) in (int, float):
        return q0 == 0 and p0 == 0
    return not (np.any(np.asarray(q0) != 0) or np.any(np.asarray(p0) != 0))


def _warn_out_of_domain(name, V, domain=None):
    from ..potentials import OutOfDomainWarning, domain_violations

    reasons = domain_violations(np.atleast_2d(V), domain)
    if reasons:
        warnings.warn(f"{name}: input outside the training distribution, the prediction "
                      f"may be inaccurate: {'; '.join(reasons)}", OutOfDomainWarning,
                      stacklevel=3)


def dop853_sensors(V, t, tol):
    """scipy's adaptive DOP853 at rtol = atol = ``tol`` on the not-a-knot spline of V.

    One trajectory at a time in Python (scipy), so milliseconds per trajectory.

    Args:
        V: sensor values (N, 100).
        t: query times (M,), ≥ 0.
        tol: relative and absolute tolerance.

    Returns:
        (q, p), each (N, M).

    Raises:
        RuntimeError: if scipy reports a failure (naming the sample).

    Example:
        >>> import nh_operators as nh
        >>> V = nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS)[None]
        >>> q, p = dop853_sensors(V, np.array([0.0, np.pi / 4]), 1e-10)
        >>> round(float(q[0, 1]), 6)  # exact: (1 - cos π) / 2
        1.0
    """
    V = np.atleast_2d(np.asarray(V, dtype=np.float64))
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    order = np.argsort(t, kind="stable")
    ts = t[order]
    q = np.empty((V.shape[0], t.size))
    p = np.empty_like(q)
    for i, v in enumerate(V):
        force = sensor_spline(v).derivative()
        sol = solve_ivp(lambda _, y, f=force: (y[1], -f(y[0])), (0.0, max(ts[-1], 1e-300)),
                        (0.0, 0.0), method="DOP853", t_eval=ts, rtol=tol, atol=tol)
        if not sol.success:
            raise RuntimeError(f"DOP853 failed on sample {i}: {sol.message}")
        q[i, order], p[i, order] = sol.y
    return q, p


def _fixed(method, substeps):
    return lambda V, t: integrate_sensors(V, t, method, substeps)


def _build_registry():
    reg = {}
    plural = {1: ""}
    for method, substeps in ([("rk4", k) for k in (1, 2, 4, 8, 16)]
                             + [("verlet", 4), ("verlet", 16), ("yoshida4", 4),
                                ("yoshida6", 2), ("yoshida8", 1), ("yoshida8", 2),
                                ("yoshida8", 4)]):
        name = f"{method}_sensors_{substeps}"
        reg[name] = ClassicalMethod(
            name, _fixed(method, substeps), f"{method}_sensors",
            description=f"{method}, {substeps} step{plural.get(substeps, 's')} per output "
                        "interval, force from the cubic spline of the sensors")
    reg["paper_rk4"] = ClassicalMethod(
        "paper_rk4", paper_rk4, "paper_rk4",
        description="the paper's RK4 row done correctly: 1 step per interval, PCHIP force")
    for tol in (1e-6, 1e-8, 1e-10, 1e-12):
        name = f"dop853_sensors_{tol:g}"
        reg[name] = ClassicalMethod(
            name, lambda V, t, tol=tol: dop853_sensors(V, t, tol), "dop853_sensors",
            batched=False, description=f"scipy DOP853, rtol = atol = {tol:g}, cubic spline "
                                       "of the sensors, one trajectory at a time")
    return reg


#: Every classical baseline, by name: fixed-step RK4, Verlet and Yoshida 4/6/8 on the
#: sensor spline, the paper-replica RK4, and DOP853 at four tolerances.
CLASSICAL_METHODS = _build_registry()

#: The baselines ``nh-operators evaluate`` reports next to the networks.
EVALUATE_BASELINES = ("rk4_sensors_1", "rk4_sensors_4", "verlet_sensors_16",
                      "yoshida4_sensors_4", "yoshida8_sensors_2", "paper_rk4")


def classical_methods(names=None):
    """The classical methods named (default: all of :data:`CLASSICAL_METHODS`).

    Args:
        names: iterable of keys of :data:`CLASSICAL_METHODS`, or None.

    Returns:
        dict name -> :class:`ClassicalMethod`, in the given order.

    Raises:
        ValueError: for an unknown name (listing the known ones).

    Example:
        >>> list(classical_methods(["paper_rk4"]))
        ['paper_rk4']
    """
    if names is None:
        return dict(CLASSICAL_METHODS)
    unknown = [n for n in names if n not in CLASSICAL_METHODS]
    if unknown:
        raise ValueError(f"unknown classical method(s) {unknown}; choose from "
                         f"{sorted(CLASSICAL_METHODS)}")
    return {n: CLASSICAL_METHODS[n] for n in names}
