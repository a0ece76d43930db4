"""``solve_many``: many potentials, states and horizons at once, each row by its own method.

A scene (an animation, a parameter sweep, an ensemble) is N rows, each a potential with
its own starting state (q0, p0) and its own times. :func:`solve_many` chooses per row,
as :func:`~nh_operators.solve` would for that row alone: with ``method="auto"`` and a
tolerance, a shipped network is tried on the rows where :func:`solve` would try it
(times in [0, 2], sensor values inside its domain; the rows at (0, 0) go to the networks
trained at rest, the others to the networks that read a starting state), each row going
to the cheapest network whose domain holds it (and on to the next where its estimate
fails; from 2 · :data:`PILOT` rows on, every candidate first answers the same
:data:`PILOT` rows, and their results there choose which networks go on and in which
order), its prediction kept where its own estimate meets the tolerance, and every other
row is solved classically — all classical rows together, in one parallel numba kernel
per substep level (:func:`~nh_operators.solvers.rows.solve_rows`), in chunks with a
progress bar when N is large. A classical row gives the same numbers as :func:`solve` on
that row.
"""

import functools
import re
import time
from dataclasses import dataclass, field

import numpy as np

from .._backend import single_threaded
from .._constants import SENSORS, TIMES
from ..potentials import BoundedPotential, check_bounded, domain_stats, in_domain
from ..solvers.rows import row_source, solve_rows
from ..solvers.schemes import _check_times
from ..solvers.states import check_states, state_arrays
from .auto_solve import DEFAULT_TOL, _calibration, _checked, _ranked, _solve
from .catalog import network_domain, reads_state
from .costs import _classical_seconds, _horizon_key, _neural_seconds
from .network_pass import _NetworkRuns, _pilot_order, _record

__all__ = ["CHUNK", "PILOT", "ManySolution", "solve_many"]

#: Classical rows per kernel call (memory stays bounded; the progress bar counts them).
CHUNK = 8192

#: Where at least twice this many rows may go to a network, every candidate first
#: answers the same this many (spread over them); a network goes on only if the rows it
#: accepted there, of those no network before it accepted, pay for its cost
#: (:func:`_pilot_order`).
PILOT = 512


#: Rows from which a progress bar is shown (``progress=None``).
PROGRESS_FROM = 20_000
#: Rows from which the classical kernels run on all of numba's threads.
THREADS_FROM = 256


@dataclass
class ManySolution:
    """What :func:`solve_many` returns.

    Attributes:
        q, p: float64 arrays (N, M), row i at row i's times, in their order.
        methods: (N,) array of method names (``"rk4"``, ``"traonet"``, ...).
        error_estimate: (N,) estimated L_tot of each row.
        neural: (N,) bool, rows a network answered.
        substeps: (N,) int, the substeps of a classical row's solution (0 for neural).
        period: (N,) T where a classical row's times were answered from one period,
            else nan.
        seconds: wall time of the whole call.
        tol: the tolerance asked for.
        tried: networks tried, with how many rows each was offered and accepted (and
            ``stopped``, why, where a pilot showed it was not worth its cost).
        records: one dict per row (built when first read): ``method``, ``kind``
            (``"classical"`` or ``"neural"``), ``error_estimate``, and for classical
            rows ``substeps`` and ``period`` (None where unused).
    """

    q: np.ndarray
    p: np.ndarray
    methods: np.ndarray
    error_estimate: np.ndarray
    neural: np.ndarray
    substeps: np.ndarray
    period: np.ndarray
    seconds: float
    tol: float = None
    tried: list = field(default_factory=list)

    @functools.cached_property
    def records(self):
        return [{"method": str(self.methods[i]),
                 "kind": "neural" if self.neural[i] else "classical",
                 "error_estimate": float(self.error_estimate[i]),
                 **({} if self.neural[i] else {
                     "substeps": int(self.substeps[i]),
                     "period": None if np.isnan(self.period[i]) else float(self.period[i])})}
                for i in range(len(self.methods))]


def _bar(total, progress):
    show = total >= PROGRESS_FROM if progress is None else bool(progress)
    if not show:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, unit="row", desc="solve_many")


def solve_many(potentials, t, *, q0=0.0, p0=0.0, tol=None, method="auto", progress=None):
    """Trajectories of N rows: each a potential, a starting state and times.

    Args:
        potentials: sensor values (N, 100); a batched
            :class:`~nh_operators.BoundedPotential`; or a list of anything
            :func:`~nh_operators.solve` takes (formulas, names, objects), solved one by
            one.
        t: times shared by every row, shape (M,), or per row, shape (N, M); ≥ 0.
        q0, p0: starting states, scalars or (N,); every energy p0²/2 + V(q0) ≤ V0.
        tol: target L_tot per row (> 0); ``None``: classical at :data:`DEFAULT_TOL`.
        method: ``"auto"``, ``"classical"``, an integrator of
            :data:`~nh_operators.METHODS`, or a shipped model (forced on every row: the
            states must be (0, 0) and the times in [0, 2]).
        progress: show a progress bar (``None``: when N ≥ 20,000).

    Returns:
        :class:`ManySolution`.

    Raises:
        ValueError: bad shapes, states, times, tolerance or method; a forced network
            on a state other than (0, 0).
        PeriodError: a row whose far horizon has no usable period (a separatrix).

    Example:
        >>> import numpy as np
        >>> V = np.stack([8 * (SENSORS - 0.5) ** 2, 2 - 7.5 * SENSORS * (1 - SENSORS)])
        >>> sol = solve_many(V, [0.5, 1e6], q0=[0.0, 0.5], p0=[0.0, 1.0], tol=1e-8)
        >>> sol.q.shape, sol.methods.tolist(), bool(sol.error_estimate.max() <= 1e-8)
        ((2, 2), ['rk4', 'rk4'], True)
    """
    start = time.perf_counter()
    rows = len(potentials) if isinstance(potentials, (list, tuple, BoundedPotential)) \
        and not (isinstance(potentials, BoundedPotential) and not potentials.batched) \
        else np.atleast_2d(np.asarray(potentials, dtype=np.float64)).shape[0]
    if rows < THREADS_FROM:  # threads only wait for time slices on a busy machine
        with single_threaded():
            return _solve_many(potentials, t, q0, p0, tol, method, progress, start)
    return _solve_many(potentials, t, q0, p0, tol, method, progress, start)


def _solve_many(potentials, t, q0, p0, tol, method, progress, start):
    method, networks, classical = _checked(method, tol)
    if isinstance(potentials, (list, tuple)):
        return _one_by_one(potentials, t, q0, p0, tol, method, start)
    if isinstance(potentials, BoundedPotential):
        if not potentials.batched:
            raise ValueError("a single BoundedPotential: use nh.solve, or pass a batch")
        src = row_source(potentials, "exact V")
        V = None
    else:
        V = check_bounded(np.atleast_2d(np.asarray(potentials, dtype=np.float64)))
        src = row_source(V, "sensors")
    n = src.params.shape[0]
    t = np.asarray(t, dtype=np.float64)
    if t.ndim == 2 and t.shape[0] == n and t.shape[1] >= 1:
        for row in t:
            _check_times(row)
    elif t.ndim <= 1:
        t = _check_times(t.reshape(-1))
    else:
        raise ValueError(f"t must have shape (M,) or (N, M) = ({n}, M); got {t.shape}")
    q0s, p0s = state_arrays(q0, p0, n)
    check_states(q0s, p0s, src.values_at, batched=True)
    target = DEFAULT_TOL if tol is None else float(tol)
    methods = np.full(n, classical.get(method, "rk4"), dtype=object)
    estimate = np.zeros(n)
    m = t.shape[-1]
    q_out, p_out = np.empty((n, m)), np.empty((n, m))
    classical_rows = np.arange(n)
    tried = []
    neural = np.zeros(n, dtype=bool)
    rest = (q0s == 0.0) & (p0s == 0.0)
    if method in networks:
        if not rest.all() and not reads_state(method):
            bad = int(np.flatnonzero(~rest)[0])
            raise ValueError(f"{method} was trained from the state (0, 0) only; row {bad} "
                             f"starts at ({q0s[bad]:g}, {p0s[bad]:g})")
        if t.max() > TIMES[-1] + 1e-12:
            raise ValueError(f"{method} predicts on t ∈ [0, 2]; got t up to {t.max():g}")
        names = [method]
    elif method == "auto" and tol is not None:
        kind = "sensors" if V is not None else "bspline"
        ids = tuple(id(_calibration(nn)) for nn in networks)
        names = [c[0] for states in (False, True)   # at rest, then from other states
                 for c in _ranked(tol, kind, ids, True, states, _horizon_key(t))[0]]
    else:
        names = []
    if names:
        values = V if V is not None else potentials.V(SENSORS)
        free = np.broadcast_to(t.max(axis=-1) <= TIMES[-1] + 1e-12, (n,)).copy()
        stats = domain_stats(values)  # once for every network's domain
        # a network for states answers the rows not at rest, the others those at rest
        eligible = {name: free & (~rest if reads_state(name) else rest)
                    & in_domain(values, network_domain(name), stats=stats)
                    if method == "auto" else free for name in names}
        out = (q_out, p_out, estimate, methods, neural, free)
        runs = _NetworkRuns(values, src, "sensors" if V is not None else "exact", t, q0s,
                            p0s, target if method == "auto" else np.inf, out)
        order, pilot = names, np.zeros(n, dtype=bool)
        if method == "auto" and free.sum() >= 2 * PILOT:
            # every candidate answers the same spread-out pilot rows; their results there
            # choose which networks go on, in which order (:func:`_pilot_order`)
            spread = np.linspace(0, free.sum() - 1, PILOT).astype(np.int64)
            pilot[np.flatnonzero(free)[spread]] = True
            results = {name: runs.run(name, np.flatnonzero(pilot & eligible[name]))
                       for name in names}  # (rows, q, p, estimate, accepted)
            costs = {name: (_classical_seconds(_calibration(name), tol, kind, True,
                                               _horizon_key(t)),
                            _neural_seconds(_calibration(name), True)) for name in names}
            order = _pilot_order(results, costs)
            for name in order:  # the pilot rows, each answered by the first that accepts
                runs.keep(name, *results[name], tried)
                runs.stop_refining(name, costs[name])
            for name in names:
                part, take = results[name][0], results[name][4]
                if name not in order and part.size:
                    _record(tried, name, part.size, 0)
                    tried[-1]["stopped"] = (f"accepted {take.mean():.1%} of a pilot of "
                                            f"{part.size} rows: not worth its cost")
        for name in order:
            part = np.flatnonzero(free & eligible[name] & ~pilot)
            if part.size:
                runs.keep(name, *runs.run(name, part), tried)
        classical_rows = np.flatnonzero(~neural)
    substeps = np.zeros(n, dtype=np.int64)
    period = np.full(n, np.nan)
    bar = _bar(classical_rows.size, progress)
    integrator = classical.get(method, "rk4")
    for lo in range(0, classical_rows.size, CHUNK):
        rows = classical_rows[lo:lo + CHUNK]
        # every row classical: a slice takes views of the parameters, not copies
        sub = src.subset(slice(lo, lo + rows.size) if classical_rows.size == n else rows)
        try:
            out = solve_rows(sub, t[rows] if t.ndim == 2 else t, q0s[rows], p0s[rows],
                             np.full(rows.size, target), integrator, batched=True)
        except ValueError as err:  # name the row of the whole call, not of the chunk
            text = re.sub(r"^row (\d+):", lambda m: f"row {rows[int(m.group(1))]}:", str(err))
            raise type(err)(text) from None
        q_out[rows], p_out[rows] = out["q"], out["p"]
        estimate[rows], substeps[rows], period[rows] = (out["estimate"], out["substeps"],
                                                        out["period"])
        if bar is not None:
            bar.update(rows.size)
    if bar is not None:
        bar.close()
    return ManySolution(q_out, p_out, methods.astype(str), estimate, neural, substeps,
                        period, time.perf_counter() - start, tol, tried)


def _one_by_one(potentials, t, q0, p0, tol, method, start):
    """A list of potentials: :func:`solve` on each row (its own compiled formula)."""
    n = len(potentials)
    q0s, p0s = state_arrays(q0, p0, n)
    t = np.asarray(t, dtype=np.float64)
    rows_t = t if t.ndim == 2 else np.broadcast_to(t.reshape(-1), (n, t.size))
    if rows_t.shape[0] != n:
        raise ValueError(f"t must have shape (M,) or (N, M) = ({n}, M); got {t.shape}")
    sols = []
    for i, pot in enumerate(potentials):
        try:
            sols.append(_solve(pot, rows_t[i], tol, method, None, time.perf_counter(),
                               float(q0s[i]), float(p0s[i])))
        except ValueError as err:
            raise type(err)(f"row {i}: {err}") from None
    neural = np.array([s.kind == "neural" for s in sols], dtype=bool)
    last = [{} if nn else s.tried[-1] for s, nn in zip(sols, neural)]  # a classical solve
    substeps = np.array([r.get("substeps") or 0 for r in last], dtype=np.int64)
    period = np.array([r.get("period") or np.nan for r in last], dtype=np.float64)
    return ManySolution(np.stack([s.q for s in sols]), np.stack([s.p for s in sols]),
                        np.array([s.method for s in sols]),
                        np.array([s.error_estimate for s in sols]), neural, substeps,
                        period, time.perf_counter() - start, tol)
