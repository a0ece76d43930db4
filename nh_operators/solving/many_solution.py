"""What :func:`~nh_operators.solving.many.solve_many` returns: one answer per row, with what
each row is and how far to trust it."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

__all__ = ["ManySolution"]


@dataclass
class ManySolution:
    """What :func:`~nh_operators.solving.many.solve_many` returns.

    Attributes:
        q, p: float64 arrays (N, M), row i at row i's times, in their order.
        methods: (N,) array of method names (``"rk4"``, ``"traonet"``, ...).
        error_estimate: (N,) estimated L_tot of each row.
        neural: (N,) bool, rows a network answered.
        substeps: (N,) int, the substeps of a classical row's solution (0 for neural).
        period: (N,) T where a classical row's times were answered from one period,
            else nan.
        converged: (N,) bool, rows whose estimate met tol (:data:`DEFAULT_TOL` when
            ``tol`` is None).
        truth: (N,) object array of :class:`~.answers.Truth`, what each row's estimate
            is measured against: the exact potential or the sensors' spline (for sensor
            values: the spline through them, not a potential they were sampled from),
            with confidence 1.0 for classical rows and a network's calibrated quantile
            (0.999) for neural ones.
        seconds: wall time of the whole call.
        tol: the tolerance asked for.
        tried: networks tried, with how many rows each was offered and accepted (and
            ``stopped``, why, where a pilot showed it was not worth its cost).
        records: one dict per row (built when first read): ``method``, ``kind``
            (``"classical"`` or ``"neural"``), ``error_estimate``, ``converged``,
            ``truth``, and for classical
            rows ``substeps`` and ``period`` (None where unused).
    """

    q: np.ndarray
    p: np.ndarray
    methods: np.ndarray
    error_estimate: np.ndarray
    neural: np.ndarray
    substeps: np.ndarray
    period: np.ndarray
    converged: np.ndarray
    truth: np.ndarray
    seconds: float
    tol: float | None = None
    tried: list = field(default_factory=list)

    @functools.cached_property
    def records(self):
        return [{"method": str(self.methods[i]),
                 "kind": "neural" if self.neural[i] else "classical",
                 "error_estimate": float(self.error_estimate[i]),
                 "converged": bool(self.converged[i]), "truth": self.truth[i],
                 **({} if self.neural[i] else {
                     "substeps": int(self.substeps[i]),
                     "period": None if np.isnan(self.period[i]) else float(self.period[i])})}
                for i in range(len(self.methods))]
