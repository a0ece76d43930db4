"""A shipped network's answer with its calibrated estimate: one call
(:func:`neural_solve`, :func:`neural_raw`) or rows of a ``solve_many`` call
(:func:`network_rows`, with a second, finer look where the estimate fails:
:mod:`~nh_operators.solving.refine`), which candidates go on after a pilot, decided on
the costs measured there (:func:`pilot_order`), and the answers kept."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._constants import SENSORS, TIMES
from .acceptance import EARLY_HORIZON
from .estimate import estimate_at, exact_force, sensor_force
from .kinds import CallKind, InputKind
from .loader import load
from .refine import REFINE, fine_estimate, refines

__all__ = [
    "NetworkRuns",
    "network_rows",
    "neural_raw",
    "neural_solve",
    "pilot_order",
    "record",
    "run_pilot",
    "sensor_values",
]

#: A network goes on past a pilot only where its measured seconds are below this share of
#: the classical seconds of the rows it accepted: both are timed on a few hundred rows
#: of a busy machine (a classical pass measured 17 to 25 µs per row on one call's rows,
#: 10,000 paper-distribution rows at tol 1e-3, one thread), and a network kept on a tie
#: makes ``auto`` slower than ``classical``.
MARGIN = 0.8

#: Rows per :func:`network_rows` call in ``solve_many``: its arrays then stay in cache (on
#: 10,000 paper-distribution rows, tol 1e-3: 16.8 µs per row in blocks of 1,024 or 512,
#: 20–23 µs in one call, one thread).
BLOCK = 1024

#: The fewest pilot rows a network is offered (fewer: its fixed cost per call would
#: weigh on its cost per row, and its share accepted would say little).
MIN_PILOT = 64


def sensor_values(pot: Any, information: str) -> np.ndarray:
    """The 100 sensor values of a coerced potential, float64 (100,)."""
    return np.asarray(pot if information == "sensors" else pot.V(SENSORS), dtype=np.float64)


def neural_solve(name: str, pot: Any, information: str, t: np.ndarray, q0: float = 0.0,
                 p0: float = 0.0) -> tuple[np.ndarray, np.ndarray, float]:
    """Predict with shipped model ``name`` on :data:`TIMES`, estimate, interpolate to t
    (from the state (q0, p0): a network that reads one); torch and numba run on one
    thread inside (:func:`~nh_operators._backend.single_threaded`).

    Returns:
        (q, p, estimate): q and p (M,); the estimate is the calibrated one, or the raw
        estimate when the model has no calibration.
    """
    from .._backend import single_threaded

    shipped = load(name)
    _ = shipped.method  # loads torch first, so that the block below limits its threads too
    with single_threaded():
        q, p, raw = neural_raw(name, pot, information, t, q0, p0)
        if shipped.calibration is None:
            return q, p, float(raw)
        early = float(np.max(t)) <= EARLY_HORIZON
        kind = InputKind.of(pot, information)
        return q, p, float(shipped.calibration.calibrated_calls(np.asarray(raw), kind, early))


def neural_raw(name: str, pot: Any, information: str, t: np.ndarray = TIMES,
               q0: float = 0.0, p0: float = 0.0) -> tuple[np.ndarray, np.ndarray, float]:
    """Model ``name``'s prediction at the times ``t`` (the spline through its prediction
    on :data:`TIMES`) from (q0, p0), and its uncalibrated estimate there
    (:func:`~nh_operators.solving.estimate.estimate_at`): (q, p, raw), q and p (M,)."""
    from ..models import predict

    shipped = load(name)
    V = sensor_values(pot, information)
    q, p = predict(shipped.net, shipped.input_rows(V[None], q0, p0), TIMES, batch_size=1)
    force = sensor_force(V) if information == "sensors" else exact_force(pot)
    qa, pa, raw = estimate_at(q, p, *force, np.asarray(t, dtype=np.float64).reshape(-1),
                              q0=q0, p0=p0)
    raw = float(raw[0])
    return qa[0], pa[0], (raw if np.isfinite(raw) else np.inf)  # inf: far outside [0, 1]


def record(tried, name, rows, accepted):
    """Count a network's rows and accepted rows in ``tried`` (one entry per network)."""
    for entry in tried:
        if entry["method"] == name:
            entry["rows"] += int(rows)
            entry["accepted"] += int(accepted)
            return
    tried.append({"method": name, "rows": int(rows), "accepted": int(accepted)})


def pilot_order(runs: NetworkRuns, names: list[str], eligible: dict, rows: np.ndarray,
                predicted: dict, classical: float, budget: float,
                tried: list) -> list[str]:
    """The networks that go on past the pilot, in order, decided on measured costs.

    The candidates ``names`` (cheapest expected first) are tried one after the other on
    the pilot rows ``rows`` that no network before them accepted (and that lie in their
    domain, ``eligible[name]``), each run timed. A network goes on when what it saved
    there pays for what it cost there, with a margin: :data:`MARGIN` · accepted ·
    ``classical`` > its seconds, ``classical`` being the classical solve's seconds per
    row measured on this call's own rows; its finer look (:mod:`.refine`) is weighed on
    its own the same way, and stopped where it does not pay. Only then are its answers
    kept.

    What a pilot may lose is bounded: before a network runs, its seconds per row are
    predicted: its calibrated seconds per row, scaled by what the last network measured
    against its own (the machine's speed now), and :data:`~.refine.REFINE` times that
    again on the share of rows expected to take the finer look. One that could not beat
    ``classical`` even accepting every row is not run; the networks that do not go on
    may spend at most ``budget`` seconds together: a network is offered only as many
    pilot rows as the budget pays for (none below :data:`MIN_PILOT`): first an eighth of
    them, after which the share that took the finer look there sets how many more (none
    where the share it accepted there would not pay for that predicted cost). Its
    seconds per row are read off that second part where there is one: the first pays
    for caches a classical pass left cold (its first forward pass after a 10,000-row
    classical pass took 5 to 10 ms more here, once per call), which the budget does not
    count. So where no network pays,
    ``auto`` costs about ``budget`` and that once more than the classical solve alone.
    The machine's speed measured so (a network's seconds per row, its finer look left
    out, over its calibrated ones, on at least :data:`MIN_PILOT` rows) scales the
    predictions of the networks after it in the same call; nothing a pilot measured is
    kept for the next call (what a network accepted, and what it cost, belong to the
    call's rows: a batch outside its domain says nothing about the next).

    Args:
        runs: the call's :class:`NetworkRuns` (answers kept in place).
        names: the candidates, in the order to try them.
        eligible: per name, the (N,) bool rows it may answer.
        rows: the pilot rows (indices).
        predicted: per name, its calibrated seconds per row and the share of rows
            expected to take the finer look (0 for a network that does not).
        classical: measured classical seconds per row (> 0).
        budget: seconds the networks that do not go on may spend.
        tried: the call's ``tried`` list (gains one entry per network run).

    Returns:
        The names that go on, in order.
    """
    order, dropped, waste = [], [], 0.0
    scale = 1.0  # the machine's speed over the calibration's, once a network measured it
    free = runs.answers.free
    for name in names:
        base, refined = predicted[name]
        per_row = base * scale * (1.0 + REFINE * refined)
        offer = rows[free[rows] & eligible[name][rows]]
        room = int(max(budget - waste, 0.0) / per_row)
        if not offer.size or per_row >= MARGIN * classical or room < min(
                MIN_PILOT, offer.size):
            continue  # nothing to offer, it cannot pay even accepting every row, or the
            # budget is spent
        offer = _spread(offer, room)
        parts = [_timed(runs, name, offer[::8])]  # warms its caches up, too
        refined = parts[0][4] / offer[::8].size  # the share it took the finer look on
        per_row = base * scale * (1.0 + REFINE * refined)
        room = int(max(budget - waste, 0.0) / per_row)
        rest = np.setdiff1d(offer, offer[::8])
        hopeful = MARGIN * parts[0][0][4].mean() * classical > per_row
        if hopeful and rest.size and room >= min(MIN_PILOT, rest.size):
            parts.append(_timed(runs, name, _spread(rest, room)))
        size = sum(part[0][0].size for part in parts)
        share = sum(int(part[0][4].sum()) for part in parts) / size
        fine_share = sum(part[2] for part in parts) / size
        # seconds per row from the last part: the first pays for cold caches
        (last, *_), seconds, _, fine_s, _ = parts[-1]
        seconds, fine_s = seconds / last.size, fine_s / last.size
        # the machine's speed now, from warm caches and enough rows (a part of a few rows
        # costs its call's fixed part: 1.1 ms per row on 4 rows set every prediction 45x)
        if len(parts) > 1 and last.size >= MIN_PILOT:
            scale = max(seconds - fine_s, 1e-12) / base
        if fine_s and MARGIN * fine_share * classical <= fine_s:  # the finer look does not pay
            runs.refined[name] = None
            share, seconds = share - fine_share, seconds - fine_s
        if MARGIN * share * classical > seconds:
            order.append(name)
            for (part_rows, q, p, estimate, accepted), *_ in parts:
                runs.keep(name, part_rows, q, p, estimate, accepted, tried)
        else:
            waste += sum(part[1] for part in parts)
            dropped.append((name, size, sum(int(p[0][4].sum()) for p in parts) / size))
    for name, size, share in dropped:  # after the ones that go on
        record(tried, name, size, 0)
        tried[-1]["stopped"] = (f"accepted {share:.1%} of a pilot of {size} rows: not worth "
                                "its cost")
    return order


def _spread(rows: np.ndarray, k: int) -> np.ndarray:
    """At most ``k`` of ``rows``, spread over them."""
    if k >= rows.size:
        return rows
    return rows[np.linspace(0, rows.size - 1, max(k, 0)).astype(np.int64)]


def _timed(runs: NetworkRuns, name: str,
           rows: np.ndarray) -> tuple[tuple[Any, ...], float, Any, Any, Any]:
    """(result of ``runs.run``, seconds, rows its finer look accepted, seconds that took,
    rows it took the finer look on)."""
    before = list(runs.refined.get(name) or [0, 0, 0.0])
    start = time.perf_counter()
    result = runs.run(name, rows)
    seconds = time.perf_counter() - start
    after = runs.refined.get(name) or before
    return result, seconds, after[1] - before[1], after[2] - before[2], after[0] - before[0]


def run_pilot(runs: NetworkRuns, names: list[str], eligible: dict, kind: InputKind,
              tol: float, tried: list, probe: Callable[[np.ndarray], float], size: int,
              budget_share: float) -> list[str]:
    """Measure what the classical solve costs on ``size`` / 4 spread-out free rows
    (``probe(rows)`` solves them classically, their answers final, and returns the
    seconds per row), then try the candidates ``names`` on up to ``size`` other
    spread-out rows (``runs.seen`` says which each answered), the networks that do not
    go on spending at most ``budget_share`` of the classical cost of the free rows
    (:func:`pilot_order`, which decides on the costs measured there).

    The candidates are tried cheapest expected first: their predicted seconds (the
    calibrated ones, and :data:`~.refine.REFINE` times that again on the share of their
    calibration set not accepted, where they take the finer look) plus that share times
    the measured classical seconds.

    Returns:
        The names that go on, in order.

    Raises:
        RuntimeError: a candidate without a calibration.
    """
    free = runs.answers.free
    spread = np.flatnonzero(free)[np.linspace(0, free.sum() - 1, size + size // 4)
                                  .astype(np.int64)]
    probe_rows = spread[::5]  # a fifth of the spread rows: size / 4
    classical = max(probe(probe_rows), 1e-12)
    free[probe_rows] = False
    rows = np.setdiff1d(spread, probe_rows)

    predicted, expected = {}, {}
    for name in names:
        cal = load(name).calibration
        if cal is None:  # ranking.ranked offers calibrated networks only
            raise RuntimeError(f"{name!r} has no calibration to weigh its pilot by")
        share = cal.acceptance_rate(tol, kind)
        # the finer look: about twice the network again on the rows the grid refuses
        predicted[name] = (cal.neural_seconds_per(True), (1.0 - share) * refines(name))
        expected[name] = (predicted[name][0] * (1.0 + REFINE * predicted[name][1])
                          + (1.0 - share) * classical)
    budget = budget_share * classical * free.sum()
    return pilot_order(runs, sorted(names, key=lambda n: expected[n]), eligible, rows,
                       predicted, classical, budget, tried)


@dataclass
class Answers:
    """What the rows of one ``solve_many`` call got so far (arrays written in place).

    Attributes:
        q, p: (N, M) the answers.
        estimate: (N,) their estimates.
        methods: (N,) object array of method names.
        neural: (N,) bool, rows a network answered.
        free: (N,) bool, rows a network may still answer.
    """

    q: np.ndarray
    p: np.ndarray
    estimate: np.ndarray
    methods: np.ndarray
    neural: np.ndarray
    free: np.ndarray


class NetworkRuns:
    """Networks run on rows of one ``solve_many`` call, their answers kept where their
    estimate meets ``target`` and the row is still free (in ``answers``, in place)."""

    def __init__(self, values, src, kind, t, q0s, p0s, target, answers: Answers):
        self.args = (values, src, kind, t)
        self.q0s, self.p0s, self.target, self.answers = q0s, p0s, target, answers
        self.refined = {}  # name: [rows estimated again, of them accepted]; None: stopped
        self.seen = {}  # name: (N,) bool, the rows it has answered (kept or not)

    def run(self, name, rows):
        """(rows, q, p, estimate, accepted) of network ``name`` on ``rows``; nothing kept.
        ``refined[name]`` counts the rows estimated again, those then accepted, and the
        seconds that took (None: the finer look stopped)."""
        if not rows.size:
            return rows, None, None, None, np.zeros(0, dtype=bool)
        self.seen.setdefault(name, np.zeros(len(self.q0s), dtype=bool))[rows] = True
        counts = self.refined.setdefault(name, [0, 0, 0.0])
        target = self.target if counts is not None else np.inf  # inf: no second look
        parts = [network_rows(name, *self.args, rows[lo:lo + BLOCK], self.q0s, self.p0s,
                              target, counts) for lo in range(0, rows.size, BLOCK)]
        q, p, est = (np.concatenate(a) for a in zip(*parts, strict=True))
        return rows, q, p, est, est <= self.target

    def keep(self, name, rows, q, p, est, accepted, tried):
        """Keep the accepted answers of rows still free, and count them in ``tried``."""
        a = self.answers
        take = accepted & a.free[rows]
        rows_taken = rows[take]
        a.q[rows_taken], a.p[rows_taken] = q[take], p[take]
        a.estimate[rows_taken], a.methods[rows_taken] = est[take], name
        a.neural[rows_taken], a.free[rows_taken] = True, False
        record(tried, name, rows.size, take.sum())


def network_rows(name: str, V: np.ndarray, src: Any, kind: InputKind, t: np.ndarray,
                 rows: np.ndarray, q0s: Any = 0.0, p0s: Any = 0.0, target: float = np.inf,
                 counts: list | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Predict rows ``rows`` with shipped model ``name`` from their states (q0s, p0s:
    scalars or one per row of V); (q, p, estimate) of those rows at their asked times
    (the estimate there too: :func:`estimate_at`, with the force of ``src``, the rows'
    :class:`~nh_operators.solvers.rows.RowSource`: the sensors' spline for sensor values,
    whose coefficients it already holds; ``kind``: the input's
    :class:`~nh_operators.solving.kinds.InputKind`); a row whose estimate exceeds
    ``target`` is estimated again on a finer grid where the network allows it
    (:mod:`~nh_operators.solving.refine`; ``counts``, a list, gains the rows estimated
    again and those then accepted, and a third item, where it has one, the seconds
    that took)."""
    from ..models import predict

    shipped = load(name)
    cal = shipped.calibration
    q0s, p0s = (np.broadcast_to(np.asarray(a, dtype=np.float64), (len(V),))[rows]
                for a in (q0s, p0s))
    q, p = predict(shipped.net, shipped.input_rows(V[rows], q0s, p0s), TIMES)

    mine = src.subset(rows)  # the rows' coefficients, taken once
    t = t if t.ndim == 1 else t[rows]
    qa, pa, raw = estimate_at(q, p, mine.values_at, lambda x: -mine.forces_at(x), t, q0=q0s,
                              p0=p0s)
    early = np.broadcast_to(t.max(axis=-1) <= EARLY_HORIZON, raw.shape)  # per row
    calibrated = raw if cal is None else cal.calibrated_calls(raw, kind, early)
    estimate = np.where(np.isfinite(raw), calibrated, np.inf)
    redo = np.flatnonzero((estimate > target) & ~early & np.isfinite(raw))
    if redo.size and refines(name):  # a finer look where the estimate failed (.refine)
        start = time.perf_counter()
        again = mine.subset(redo)
        qf, pf, raw_f = fine_estimate(name, V[rows[redo]], again.values_at,
                                      lambda x: -again.forces_at(x),
                                      t if t.ndim == 1 else t[redo], q0s[redo], p0s[redo])
        fine_cal = raw_f if cal is None else cal.calibrated(raw_f, kind, CallKind.FINE)
        fine = np.where(np.isfinite(raw_f), fine_cal, np.inf)
        ok = fine <= target
        qa[redo[ok]], pa[redo[ok]], estimate[redo[ok]] = qf[ok], pf[ok], fine[ok]
        if counts is not None:
            counts[0] += redo.size
            counts[1] += int(ok.sum())
            if len(counts) > 2:
                counts[2] += time.perf_counter() - start
    return qa, pa, estimate
