"""The networks' pass of :func:`~nh_operators.solving.many.solve_many`: a network's
prediction and estimate on rows of the call (a second, finer look where the estimate
fails: :mod:`~nh_operators.solving.refine`), the order in which the candidates go on
after a pilot, and the answers kept."""

import numpy as np

from .._constants import TIMES
from .acceptance import EARLY_HORIZON, calibrated
from .auto_solve import _model, network_input
from .estimate import estimate_at
from .refine import fine_estimate, refines

__all__ = []


def _record(tried, name, rows, accepted):
    """Count a network's rows and accepted rows in ``tried`` (one entry per network)."""
    for entry in tried:
        if entry["method"] == name:
            entry["rows"] += int(rows)
            entry["accepted"] += int(accepted)
            return
    tried.append({"method": name, "rows": int(rows), "accepted": int(accepted)})


def _pilot_order(results, costs):
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
        >>> _pilot_order(results([1]), costs)  # a accepts nothing b did not
        ['b']
        >>> _pilot_order(results([0]), costs)  # alone, a would not pay; after b it does
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


class _NetworkRuns:
    """Networks run on rows of one ``solve_many`` call, their answers kept where their
    estimate meets ``target`` and the row is still free (``out``: the call's q, p,
    estimate, methods, neural and free arrays, written in place)."""

    def __init__(self, values, src, kind, t, q0s, p0s, target, out):
        self.args = (values, src, kind, t)
        self.q0s, self.p0s, self.target, self.out = q0s, p0s, target, out
        self.refined = {}  # name: [rows estimated again, of them accepted]; None: stopped

    def run(self, name, rows):
        """(rows, q, p, estimate, accepted) of network ``name`` on ``rows``; nothing kept."""
        if not rows.size:
            return rows, None, None, None, np.zeros(0, dtype=bool)
        counts = self.refined.setdefault(name, [0, 0])
        target = self.target if counts is not None else np.inf  # inf: no second look
        q, p, est = _network_rows(name, *self.args, rows, self.q0s, self.p0s, target,
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
        q_out, p_out, estimate, methods, neural, free = self.out
        take = accepted & free[rows]
        rows_taken = rows[take]
        q_out[rows_taken], p_out[rows_taken] = q[take], p[take]
        estimate[rows_taken], methods[rows_taken] = est[take], name
        neural[rows_taken], free[rows_taken] = True, False
        _record(tried, name, rows.size, take.sum())


def _network_rows(name, V, src, kind, t, rows, q0s=0.0, p0s=0.0, target=np.inf,
                  counts=None):
    """Predict rows ``rows`` with shipped model ``name`` from their states (q0s, p0s:
    scalars or one per row of V); (q, p, estimate) of those rows at their asked times
    (the estimate there too: :func:`estimate_at`, with the force of ``src``, the rows'
    :class:`~nh_operators.solvers.rows.RowSource`: the sensors' spline for sensor values,
    whose coefficients it already holds; ``kind``: ``"sensors"`` or ``"exact"``); a row
    whose estimate exceeds ``target`` is estimated again on a finer grid where the
    network allows it (:mod:`~nh_operators.solving.refine`; ``counts``, a list, gains
    the rows estimated again and those then accepted)."""
    from ..models import predict

    model = _model(name)
    q0s, p0s = (np.broadcast_to(np.asarray(a, dtype=np.float64), (len(V),))[rows]
                for a in (q0s, p0s))
    q, p = predict(model.net, network_input(name, V[rows], q0s, p0s), TIMES)

    mine = src.subset(rows)  # the rows' coefficients, taken once
    t = t if t.ndim == 1 else t[rows]
    qa, pa, raw = estimate_at(q, p, mine.values_at, lambda x: -mine.forces_at(x), t, q0=q0s,
                              p0=p0s)
    early = np.broadcast_to(t.max(axis=-1) <= EARLY_HORIZON, raw.shape)  # per row
    estimate = np.where(np.isfinite(raw), calibrated(raw, model.calibration, kind, early),
                        np.inf)
    redo = np.flatnonzero((estimate > target) & ~early & np.isfinite(raw))
    if redo.size and refines(name):  # a finer look where the estimate failed (.refine)
        again = mine.subset(redo)
        qf, pf, raw_f = fine_estimate(name, V[rows[redo]], again.values_at,
                                      lambda x: -again.forces_at(x),
                                      t if t.ndim == 1 else t[redo], q0s[redo], p0s[redo])
        fine = np.where(np.isfinite(raw_f), calibrated(raw_f, model.calibration, kind,
                                                       fine=True), np.inf)
        ok = fine <= target
        qa[redo[ok]], pa[redo[ok]], estimate[redo[ok]] = qf[ok], pf[ok], fine[ok]
        if counts is not None:
            counts[0] += redo.size
            counts[1] += int(ok.sum())
    return qa, pa, estimate
