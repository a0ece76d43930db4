"""``solve_many``: many potentials, states and horizons at once, each row by its own method.

A scene (an animation, a parameter sweep, an ensemble) is N rows, each a potential with
its own starting state (q0, p0) and its own times. :func:`solve_many` chooses per row,
as :func:`~nh_operators.solve` would for that row alone: with ``method="auto"`` and a
tolerance, a shipped network is tried on the rows where :func:`solve` would try it
(times in [0, 2], sensor values inside its domain; the rows at (0, 0) go to the networks
trained at rest, the others to the networks that read a starting state), each row going
to the cheapest network whose domain holds it (and on to the next where its estimate
fails), its prediction kept where its own estimate meets the tolerance, and every other
row is solved classically. From 2 · :data:`PILOT` rows on, costs are measured, not
trusted: a quarter of :data:`PILOT` rows are solved classically first and timed, the
candidates are then tried on :data:`PILOT` rows, timed, and a network goes on only where
what it accepted there pays for what it cost there; networks that do not go on may
spend at most :data:`PILOT_BUDGET` of the classical cost, so ``auto`` is never much
slower than ``classical`` (:func:`~.network_pass.pilot_order`). Rows left are solved
classically — all classical rows together, in one parallel numba kernel
per substep level (:func:`~nh_operators.solvers.rows.solve_rows`), in chunks with a
progress bar when N is large. A classical row gives the same numbers as :func:`solve` on
that row.

Each row says what it is, ``converged`` and ``truth`` (:mod:`~nh_operators.solving.answers`).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._backend import single_threaded
from .._constants import SENSORS, TIMES
from ..potentials import BoundedPotential, check_bounded, domain_stats, in_domain
from ..solvers.row_error import RowError, about_row
from ..solvers.rows import row_source, solve_rows
from ..solvers.schemes import check_times
from ..solvers.states import check_states, state_arrays
from .answers import MAX_SUBSTEPS, row_truths
from .auto_solve import solve
from .costs import horizon_key, measured_seconds, remember_seconds
from .kinds import InputKind
from .loader import load
from .many_solution import ManySolution
from .network_pass import Answers, NetworkRuns, run_pilot
from .ranking import CLASSICAL, DEFAULT_TOL, check_method, ranked

__all__ = ["CHUNK", "PILOT", "ManySolution", "solve_many"]

#: Classical rows per kernel call (memory stays bounded; the progress bar counts them).
CHUNK = 8192

#: Where at least twice this many rows may go to a network, the candidates are first
#: tried on this many (spread over them), one after the other on the rows no network
#: before accepted; a network goes on only if the rows it accepted there pay for what it
#: cost there, measured (:func:`~.network_pass.pilot_order`).
PILOT = 512
#: Networks that do not go on may spend at most this share of the classical cost of the
#: call's free rows in the pilot: what ``auto`` may lose to classical where no network
#: pays.
PILOT_BUDGET = 0.03


#: Rows from which a progress bar is shown (``progress=None``).
PROGRESS_FROM = 20_000
#: Rows from which the classical kernels run on all of numba's threads.
THREADS_FROM = 256


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
        :class:`ManySolution`. Per row, :func:`~nh_operators.solve`'s promise: where
        ``converged``, the estimate is ≤ tol against ``truth`` (for sensor values the
        sensors' spline), certain on a classical row, at the calibrated quantile (0.999)
        on a neural one; a row tol cannot be reached on keeps its finest answer.

    Raises:
        ValueError: bad shapes, states, times, tolerance or method; a forced network
            on a state other than (0, 0).
        PeriodError: a row whose far horizon has no usable period (a separatrix).

    Warns:
        RuntimeWarning: rows whose tol the classical solver did not reach.
        UserWarning: a forced network's rows whose estimate exceeds ``tol``.

    Thread safety: below :data:`THREADS_FROM` rows the call sets torch's and numba's
    process-wide thread counts to 1 and restores them on return, as
    :func:`~nh_operators.solve` does (not thread-safe: see ``docs/solve.md``,
    "Threads"); from it on, it leaves them alone.

    Example:
        >>> import numpy as np
        >>> V = np.stack([8 * (SENSORS - 0.5) ** 2, 2 - 7.5 * SENSORS * (1 - SENSORS)])
        >>> sol = solve_many(V, [0.5, 1e6], q0=[0.0, 0.5], p0=[0.0, 1.0], tol=1e-8)
        >>> sol.q.shape, sol.methods.tolist(), sol.converged.tolist(), str(sol.truth[0])
        ((2, 2), ['rk4', 'rk4'], [True, True], 'sensor spline')
    """
    start = time.perf_counter()
    rows = len(potentials) if isinstance(potentials, (list, tuple, BoundedPotential)) \
        and not (isinstance(potentials, BoundedPotential) and not potentials.batched) \
        else np.atleast_2d(np.asarray(potentials, dtype=np.float64)).shape[0]
    if rows < THREADS_FROM:  # threads only wait for time slices on a busy machine
        with single_threaded():
            return _solve_many(potentials, t, q0, p0, tol, method, progress, start)
    return _solve_many(potentials, t, q0, p0, tol, method, progress, start)


@dataclass(frozen=True)
class _Call:
    """The rows of one ``solve_many`` call, checked: their force source ``src``, sensor
    values ``V`` (None for a batched B-spline, ``potentials`` then), input kind, times t
    ((M,) or (N, M)) and states (q0s, p0s, (N,))."""

    potentials: Any
    src: Any
    V: np.ndarray | None
    kind: InputKind
    t: np.ndarray
    q0s: np.ndarray
    p0s: np.ndarray

    @property
    def n(self) -> int:
        return len(self.q0s)

    @property
    def values(self) -> np.ndarray:
        """The sensor values (N, 100)."""
        return self.V if self.V is not None else self.potentials.V(SENSORS)


def _solve_many(potentials, t, q0, p0, tol, method, progress, start):
    method, networks = check_method(method, tol)
    if isinstance(potentials, (list, tuple)):
        return _one_by_one(potentials, t, q0, p0, tol, method, start)
    call = _checked_call(potentials, t, q0, p0)
    target = DEFAULT_TOL if tol is None else float(tol)
    n, m = call.n, call.t.shape[-1]
    answers = Answers(np.empty((n, m)), np.empty((n, m)), np.zeros(n),
                      np.full(n, CLASSICAL.get(method, "rk4"), dtype=object),
                      np.zeros(n, dtype=bool), np.zeros(n, dtype=bool))
    tried, integrator = [], CLASSICAL.get(method, "rk4")
    substeps, period = np.zeros(n, dtype=np.int64), np.full(n, np.nan)
    done = np.zeros(n, dtype=bool)  # rows already solved classically (a pilot's probe)

    def probe(rows: np.ndarray) -> float:
        return _classical_probe(call, rows, integrator, target, answers, substeps, period,
                                done)

    names = _candidates(call, method, tol, networks)
    if names:
        _network_pass(call, names, method, tol, target, answers, tried, probe)
    # no row went to a network: all rows in one pass (views, not copies; the probe's
    # rows come out the same, row by row)
    left = ~answers.neural & ~done if answers.neural.any() else ~answers.neural
    _classical_pass(call, np.flatnonzero(left), integrator, target, answers, substeps,
                    period, progress)
    converged = answers.estimate <= target
    if method in networks and tol is not None and not converged.all():
        bad = np.flatnonzero(~converged)
        warnings.warn(f"{method}'s error estimate exceeds tol {tol:g} on {bad.size} rows "
                      f"(row {bad[0]}: {answers.estimate[bad[0]]:.2g}); use method='auto' "
                      "to fall back to the classical solver", UserWarning, stacklevel=4)
    return ManySolution(answers.q, answers.p, answers.methods.astype(str), answers.estimate,
                        answers.neural, substeps, period, converged,
                        row_truths(call.kind, answers.methods, answers.neural),
                        time.perf_counter() - start, tol, tried)


def _checked_call(potentials, t, q0, p0) -> _Call:
    """The call's rows, times and states, or a clear error."""
    if isinstance(potentials, BoundedPotential):
        if not potentials.batched:
            raise ValueError("a single BoundedPotential: use nh.solve, or pass a batch")
        kind, V = InputKind.BSPLINE, None
        src = row_source(potentials, kind.information)
    else:
        V = check_bounded(np.atleast_2d(np.asarray(potentials, dtype=np.float64)))
        kind = InputKind.SENSORS
        src = row_source(V, kind.information)
    n = src.params.shape[0]
    t = np.asarray(t, dtype=np.float64)
    if t.ndim == 2 and t.shape[0] == n and t.shape[1] >= 1:
        for row in t:
            check_times(row)
    elif t.ndim <= 1:
        t = check_times(t.reshape(-1))
    else:
        raise ValueError(f"t must have shape (M,) or (N, M) = ({n}, M); got {t.shape}")
    q0s, p0s = state_arrays(q0, p0, n)
    check_states(q0s, p0s, src.values_at, batched=True)  # a RowError names the row
    return _Call(potentials, src, V, kind, t, q0s, p0s)


def _candidates(call: _Call, method: str, tol: float | None,
                networks: tuple[str, ...]) -> list[str]:
    """The networks to try, in order: a forced one (checked), or with ``auto`` and a
    tolerance the ones expected to be cheaper per row (at rest, then from other states)."""
    t, rest = call.t, (call.q0s == 0.0) & (call.p0s == 0.0)
    if method in networks:
        if not rest.all() and not load(method).reads_state:
            bad = int(np.flatnonzero(~rest)[0])
            raise ValueError(f"{method} was trained from the state (0, 0) only; row {bad} "
                             f"starts at ({call.q0s[bad]:g}, {call.p0s[bad]:g})")
        if t.max() > TIMES[-1] + 1e-12:
            raise ValueError(f"{method} predicts on t ∈ [0, 2]; got t up to {t.max():g}")
        return [method]
    if method == "auto" and tol is not None:
        return [c[0] for states in (False, True)   # at rest, then from other states
                for c in ranked(tol, call.kind, True, states, horizon_key(t))[0]]
    return []


def _network_pass(call: _Call, names: list[str], method: str, tol: float | None,
                  target: float, answers: Answers, tried: list,
                  probe: Callable[[np.ndarray], float]) -> None:
    """Networks ``names`` answer the rows they may (in ``answers``, in place): each row
    goes to the first whose estimate meets ``target``; from 2 · :data:`PILOT` free rows on
    (``auto``), a pilot decides which networks go on, on costs measured there
    (:func:`~.network_pass.run_pilot`; ``probe(rows)`` solves rows classically and
    returns the seconds per row)."""
    n, t, auto = call.n, call.t, method == "auto"
    values = call.values
    rest = (call.q0s == 0.0) & (call.p0s == 0.0)
    answers.free[:] = np.broadcast_to(t.max(axis=-1) <= TIMES[-1] + 1e-12, (n,))
    free = answers.free
    stats = domain_stats(values)  # once for every network's domain
    # a network for states answers the rows not at rest, the others those at rest
    eligible = {name: free & (~rest if load(name).reads_state else rest)
                & in_domain(values, load(name).domain, stats=stats)
                if auto else free.copy() for name in names}
    runs = NetworkRuns(values, call.src, call.kind, t, call.q0s, call.p0s,
                       target if auto else np.inf, answers)
    order = names
    if auto and tol is not None and free.sum() >= 2 * PILOT:  # auto tries networks at a tol
        order = run_pilot(runs, names, eligible, call.kind, tol, tried, probe, PILOT,
                          PILOT_BUDGET)
    for name in order:  # each on the free rows it may answer and has not answered yet
        seen = runs.seen.get(name)
        part = np.flatnonzero(free & eligible[name] & (True if seen is None else ~seen))
        if part.size:
            runs.keep(name, *runs.run(name, part), tried)


def _classical_probe(call: _Call, rows: np.ndarray, integrator: str, target: float,
                     answers: Answers, substeps: np.ndarray, period: np.ndarray,
                     done: np.ndarray) -> float:
    """Solve rows ``rows`` classically (their answers final, marked in ``done``) and
    return the seconds per row it took: the classical cost a network must beat, measured
    on this call's rows, at its tolerance, on this machine as it is now; or, where less,
    what the last classical pass of :data:`PILOT` rows or more in this process cost per
    row in such a call (:func:`~.costs.measured_seconds`)."""
    start = time.perf_counter()
    _classical_pass(call, rows, integrator, target, answers, substeps, period, False)
    done[rows] = True
    seconds = (time.perf_counter() - start) / max(rows.size, 1)
    return min(seconds, measured_seconds(_cost_key(call, integrator, target)))


def _cost_key(call: _Call, integrator: str, target: float) -> tuple:
    return call.kind, integrator, target, horizon_key(call.t), call.t.ndim


def _classical_pass(call: _Call, rows_left: np.ndarray, integrator: str, target: float,
                    answers: Answers, substeps: np.ndarray, period: np.ndarray,
                    progress: bool | None) -> None:
    """Solve rows ``rows_left`` classically, :data:`CHUNK` at a time (in ``answers``,
    and their substeps and period in ``substeps`` and ``period``, in place).

    Raises:
        RowError: a bad row, named by its index in the call.
    """
    n, t = call.n, call.t
    start = time.perf_counter()
    bar = _bar(rows_left.size, progress)
    for lo in range(0, rows_left.size, CHUNK):
        rows = rows_left[lo:lo + CHUNK]
        # every row classical: a slice takes views of the parameters, not copies
        sub = call.src.subset(slice(lo, lo + rows.size) if rows_left.size == n else rows)
        try:
            out = solve_rows(sub, t[rows] if t.ndim == 2 else t, call.q0s[rows],
                             call.p0s[rows], np.full(rows.size, target), integrator,
                             MAX_SUBSTEPS, batched=True)
        except RowError as err:  # name the row of the whole call, not of the chunk
            if err.row is None:
                raise
            raise err.renumbered(int(rows[err.row])) from None
        if rows.size == n:  # one chunk of every row, in order: its arrays are the answers
            answers.q, answers.p = out.q, out.p
        else:
            answers.q[rows], answers.p[rows] = out.q, out.p
        answers.estimate[rows], substeps[rows], period[rows] = (
            out.estimate, out.substeps, out.period)
        if bar is not None:
            bar.update(rows.size)
    if bar is not None:
        bar.close()
    if rows_left.size >= PILOT:
        remember_seconds(_cost_key(call, integrator, target),
                           (time.perf_counter() - start) / rows_left.size)


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
            sols.append(solve(pot, rows_t[i], tol=tol, method=method, q0=float(q0s[i]),
                              p0=float(p0s[i])))
        except ValueError as err:
            raise about_row(err, i) from None
    neural = np.array([s.kind == "neural" for s in sols], dtype=bool)
    # a classical solve's last try (neural has one entry per solution)
    last = [{} if nn else s.tried[-1] for s, nn in zip(sols, neural, strict=True)]
    substeps = np.array([r.get("substeps") or 0 for r in last], dtype=np.int64)
    period = np.array([r.get("period") or np.nan for r in last], dtype=np.float64)
    truth = np.empty(n, dtype=object)
    truth[:] = [s.truth for s in sols]
    return ManySolution(np.stack([s.q for s in sols]), np.stack([s.p for s in sols]),
                        np.array([s.method for s in sols]),
                        np.array([s.error_estimate for s in sols]), neural, substeps,
                        period, np.array([s.converged for s in sols], dtype=bool), truth,
                        time.perf_counter() - start, tol)
