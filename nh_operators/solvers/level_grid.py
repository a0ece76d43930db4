"""The step grids of the doubling's levels, and how a level's gap is read as an estimate.

:func:`level_grid` fixes, per row, the substeps of the first level (``RESOLVED_STEP``, or
coarser from :func:`~.start_level.start_levels`) and the output interval they divide,
and :func:`estimate_rule` how the gaps of two pairs of levels bound the error: shrunk at
the method's rate on a C² potential, and not at all (times :data:`KINK_SAFETY`) on a row
whose orbit crosses a kink.
"""

from dataclasses import dataclass

import numpy as np

from .periodic import HorizonPlan, default_interval
from .schemes import ORDERS
from .start_level import RESOLVED_STEP

__all__ = ["DEEP_GAPS", "KINK_SAFETY", "LevelGrid", "estimate_rule", "level_grid"]

#: The gaps a row whose orbit crosses a kink counts, unshrunk (``LevelGrid.deep``). Chosen
#: by replaying RK4's levels on the 2,488 orbits past a spline's ``OUTSIDE_MARGIN`` among
#: 6,000 out-of-distribution sensor rows (seeds 9001–9003; truth RK4 ×16,384): at tol 1e-6
#: to 1e-9, 2 gaps × KINK_SAFETY let 3–6 answers over tol (up to 12×), 3 gaps 1 (1.2×),
#: 4 none (worst 0.94); on seeds 9004–9005 (1,640 such rows) 4 gaps none either (0.88).
DEEP_GAPS = 4

#: Factor on the classical estimate of a potential that is not C² (a kink), whose
#: level errors jump about: on the MFF from random states a factor 1 still let answers
#: over tol (up to 4.5x at 1e-8), 10 none of those tried.
KINK_SAFETY = 10.0


@dataclass(frozen=True)
class LevelGrid:
    """The step grids of the levels and how a level's error is weighed (final).

    Attributes:
        work: (N, W) sorted working times (of :func:`~.periodic.plan_horizon`).
        interval: (N,) the output interval over ``first``: level s takes s steps in it.
        first: (N,) float, the substeps per output interval of level 1 (a power of 2;
            below 1 only from a start 4 levels coarser, whose accepted levels are whole).
        shared: every row has row 0's times and grid (the lockstep kernel).
        weight: (1, W) for every row, or (N, W): the share of each working time in the
            mean gap of two levels.
        with_t: (N,) rows answered from one period, whose last working time is T.
        method: a key of :data:`~nh_operators.METHODS`.
        rate, safety: (N,) the shrink of the previous gap per level, and the factor on
            the estimate (:func:`estimate_rule`).
        deep: (N,) bool, rows whose estimate counts the last :data:`DEEP_GAPS` gaps,
            unshrunk: those whose orbit crosses a kink (``kinked``).
    """

    work: np.ndarray
    interval: np.ndarray
    first: np.ndarray
    shared: bool
    weight: np.ndarray
    with_t: np.ndarray
    method: str
    rate: np.ndarray
    safety: np.ndarray
    deep: np.ndarray


def level_grid(src, plan: HorizonPlan, ts, shared_times, method, coarse, kinked):
    """The :class:`LevelGrid` of a solve.

    Args:
        src: the :class:`~.rows.RowSource`.
        plan: its :class:`~.periodic.HorizonPlan`; ``ts`` (N, M) the sorted asked times;
            ``shared_times``: every row asked the same times.
        method: a key of :data:`~nh_operators.METHODS`.
        coarse: (N,) int, the levels each row starts coarser than ``RESOLVED_STEP``.
        kinked: (N,) bool, rows whose orbit crosses a kink of V (besides a potential
            marked not C² as a whole): :func:`estimate_rule`, and :data:`DEEP_GAPS`
            gaps of evidence (``deep``): an orbit past a spline's ``OUTSIDE_MARGIN``,
            where its force is held, had level errors 1.3e-8, 1.7e-8, 1.9e-8 at 8, 16,
            32 substeps and 2.3e-10 at 64 (seed 9003, row 493:
            ``tests/solvers/data/ood_past_guard_plateau.npz``): small gaps by chance.
    """
    n, m = ts.shape
    periodic, column, work = plan.periodic, plan.column, plan.work
    # one grid for all rows: shared times, none answered from a period
    # (column None: no row answered from a period, work = asked times)
    shared = shared_times and column is None and (n == 1 or bool(np.all(coarse == coarse[0])))
    interval = (np.full(n, default_interval(ts[:1], periodic[:1])[0]) if shared
                else default_interval(ts, periodic))
    # level 1: steps of RESOLVED_STEP (2^coarse × that at loose tols), `first` per
    # interval: at most 1 step per interval up to coarse 3, 2^(coarse-3) intervals beyond
    first = 2.0 ** np.maximum(np.ceil(np.log2(interval / RESOLVED_STEP) - 1e-9) - coarse,
                              np.minimum(0, 3 - coarse))
    # rows answered from one period: their work column m is T, whose return to the
    # start is checked after the solve; other rows have a copy of their last time there
    with_t = periodic & np.isfinite(plan.period)
    # the estimate averages the asked times and, for a row answered from one period, T
    if column is None:  # every work time is asked; one row of weights for all
        weight = np.full((1, m), 1.0 / m)
    else:
        weight = np.full(work.shape, 1.0 / (m + 1))
        weight[~with_t] = 1.0 / m
        weight[~with_t, m] = 0.0
    rate, safety = estimate_rule(src, method, kinked)
    return LevelGrid(work, interval / first, first, shared, weight, with_t, method, rate,
                     safety, np.asarray(kinked, dtype=bool))


def estimate_rule(src, method, kinked):
    """(rate, safety), (N,) each: how much the previous gap may be shrunk, and the factor
    on the estimate, per row.

    By the method's rate on a C² potential; across a kink the level errors jump about
    (MFF from (0.47, 1.43): gaps 1.4e-7, 8.2e-6, 2.3e-6 at 256, 512, 1024 substeps), so
    there both gaps, times KINK_SAFETY, must meet tol.
    """
    smooth = src.smooth & ~np.asarray(kinked, dtype=bool)
    rate = np.where(smooth, 4.0 ** min(ORDERS[method], 4), 1.0)
    safety = np.where(smooth, 1.0, KINK_SAFETY)
    return rate, safety
