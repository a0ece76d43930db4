"""Where the classical doubling starts: the resolved step, and how much coarser a loose
tolerance may start (issue 41, "a cheaper proof").

The doubling of :func:`~.rows.solve_rows` accepts a level only on evidence (the last two
gaps), so every level below the accepted one is work spent on the proof. At a loose
tolerance a coarser first level still gives evidence that holds: the thresholds here were
chosen on ``benchmarks/promise/classical_estimate.py`` (docs: solve, "A cheaper start")
and checked on fresh seeds, with no answer over tol.
"""

from .._constants import TIMES

__all__ = ["COARSEST_START_TOL", "COARSER_START_TOL", "COARSE_START_TOL", "RESOLVED_STEP",
           "START_TOLS", "start_coarseness"]

#: The coarsest step the doubling starts from: 1/8 of the spacing of :data:`TIMES`
#: (:mod:`.classical_solve`). At the largest speed a generator potential gives (about 2.8)
#: it moves the particle 0.007 per step, less than the sensor spacing 1/99, so no level
#: used as evidence steps over the features of V.
RESOLVED_STEP = (TIMES[1] - TIMES[0]) / 8.0

#: From these tols up (all rows) the doubling starts 1, 2, 3 levels coarser than
#: :data:`RESOLVED_STEP` (:data:`START_TOLS` rules); the coarsest level only floors the
#: estimate. Chosen on ``benchmarks/promise/classical_estimate.py`` (docs: solve, "A
#: cheaper start").
COARSE_START_TOL, COARSER_START_TOL, COARSEST_START_TOL = 1e-8, 1e-6, 1e-3
#: The thresholds :func:`start_coarseness` counts, read at call time (a benchmark may
#: set others for its own process: ``classical_estimate.py --start K``).
START_TOLS = (COARSE_START_TOL, COARSER_START_TOL, COARSEST_START_TOL)


def start_coarseness(tol: float) -> int:
    """How many levels coarser than :data:`RESOLVED_STEP` a solve to ``tol`` starts.

    Args:
        tol: the loosest target L_tot of the rows solved together.

    Returns:
        How many of :data:`START_TOLS` (read at call time) ``tol`` reaches.

    Example:
        >>> start_coarseness(1e-3), start_coarseness(1e-6), start_coarseness(1e-12)
        (3, 2, 0)
    """
    return sum(int(tol >= s) for s in START_TOLS)
