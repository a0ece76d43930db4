"""A shipped network's answer with its calibrated estimate: one call
(:func:`neural_solve`, :func:`neural_raw`) or rows of a ``solve_many`` call
(:func:`network_rows`, with a second, finer look where the estimate fails:
:mod:`~nh_operators.solving.refine`), the order in which the candidates go on after a
pilot, and the answers kept."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._constants import SENSORS, TIMES
from .acceptance import EARLY_HORIZON
from .estimate import estimate_at, exact_force, sensor_force
from .kinds import CallKind, InputKind
from .loader import load
from .refine import fine_estimate, refines

__all__ = [
    "NetworkRuns",
    "network_rows",
    "neural_raw",
    "neural_solve",
    "pilot_order",
    "record",
    "sensor_values",
]


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


def pilot_order(results: dict, costs: dict) -> list[str]:
    """The networks that go on past the pilot, in order.

    ``results[name]``: (rows, q, p, estimate, accepted) of each network on its pilot rows;
    ``costs[name]``: (classical, network) seconds per row. Greedily, the next network is
    the one whose pilot rows that no network before it accepted would save the most
    (share accepted · classical − network, per row offered); a network that saves
    nothing there does not go on.

    Example:
        >>> rows, costs = np.arange(4), {"a": (1.0, 0.3), "b": (1.0, 0.3)}
        >>> def results(a):  # b accepts rows 1 and 2, a the rows given
        ...     return {"a": (rows, None, None, None, np.isin(rows, a)),
        ...             "b": (rows, None, None, None, np.isin(rows, [1, 2]))}
        >>> pilot_order(results([1]), costs)  # a accepts nothing b did not
        ['b']
        >>> pilot_order(results([0]), costs)  # alone, a would not pay; after b it does
        ['b', 'a']
    """
    order, answered = [], np.zeros(0, dtype=np.int64)
    while True:
        best, gain = None, 0.0
        for name, (rows, *_, accepted) in results.items():
            open_ = ~np.isin(rows, answered)
            if name in order or not open_.any():
                continue
            classical, network = costs[name]
            saving = open_.sum() * (accepted[open_].mean() * classical - network)
            if saving > gain:
                best, gain = name, saving
        if best is None:
            return order
        order.append(best)
        rows, *_, accepted = results[best]
        answered = np.union1d(answered, rows[accepted])


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

    def run(self, name, rows):
        """(rows, q, p, estimate, accepted) of network ``name`` on ``rows``; nothing kept."""
        if not rows.size:
            return rows, None, None, None, np.zeros(0, dtype=bool)
        counts = self.refined.setdefault(name, [0, 0])
        target = self.target if counts is not None else np.inf  # inf: no second look
        q, p, est = network_rows(name, *self.args, rows, self.q0s, self.p0s, target,
                                  counts)
        return rows, q, p, est, est <= self.target

    def stop_refining(self, name, costs):
        """After a pilot: stop the finer look (:mod:`.refine`) of network ``name`` where
        the share of rows it turned accepted does not pay for it (costs: classical and
        network seconds per row; the finer look is taken as twice the network's)."""
        counts = self.refined.get(name)
        if counts and counts[0] and counts[1] / counts[0] * costs[0] < 2.0 * costs[1]:
            self.refined[name] = None

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
    again and those then accepted)."""
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
    return qa, pa, estimate
