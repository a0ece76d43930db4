"""Where the classical doubling starts: the resolved step, and the coarser starts that were
tried at loose tolerances and are off (issue 41, "a cheaper proof").

The doubling of :func:`~.rows.solve_rows` accepts a level only on evidence (the last two
gaps), so every level below the accepted one is work spent on the proof, and a coarser
first level would make the proof cheaper. Starting 1, 2 or 3 levels coarser from tol
1e-8, 1e-6 and 1e-3 up held on the families of ``benchmarks/promise/classical_estimate.py``
(generator potentials as curves and as sensor values, 20 out-of-distribution formulas per
draw), but not on 2,000 out-of-distribution potentials given as sensor values
(``benchmarks/promise/sensor_contract.py --seed 7001|7002|7003``): three coarse levels
agreed by chance on orbits that pass slowly over a barrier just below V0, and answers
missed tol by up to 43× (docs: solve, "A cheaper start"). So :data:`START_TOLS` is empty
and every solve starts at :data:`RESOLVED_STEP`; the thresholds stay named, and a process
may set :data:`START_TOLS` to measure them (``classical_estimate.py --start K``).
"""

from .._constants import TIMES

__all__ = ["COARSEST_START_TOL", "COARSER_START_TOL", "COARSE_START_TOL", "RESOLVED_STEP",
           "START_TOLS", "start_coarseness"]

#: The coarsest step the doubling starts from: 1/8 of the spacing of :data:`TIMES`
#: (:mod:`.classical_solve`). At the largest speed a generator potential gives (about 2.8)
#: it moves the particle 0.007 per step, less than the sensor spacing 1/99, so no level
#: used as evidence steps over the features of V.
RESOLVED_STEP = (TIMES[1] - TIMES[0]) / 8.0

#: The tols from which a start 1, 2, 3 levels coarser than :data:`RESOLVED_STEP` was
#: tried (chosen on ``benchmarks/promise/classical_estimate.py``; off: see the module).
COARSE_START_TOL, COARSER_START_TOL, COARSEST_START_TOL = 1e-8, 1e-6, 1e-3
#: The thresholds :func:`start_coarseness` counts, read at call time: none (every solve
#: starts resolved); ``(COARSE_START_TOL, COARSER_START_TOL, COARSEST_START_TOL)`` is the
#: rule that was tried.
START_TOLS: tuple[float, ...] = ()


def start_coarseness(tol: float) -> int:
    """How many levels coarser than :data:`RESOLVED_STEP` a solve to ``tol`` starts.

    Args:
        tol: the loosest target L_tot of the rows solved together.

    Returns:
        How many of :data:`START_TOLS` (read at call time) ``tol`` reaches: 0 with the
        default (empty) rule.

    Example:
        >>> start_coarseness(1e-3), start_coarseness(1e-12)
        (0, 0)
    """
    return sum(int(tol >= s) for s in START_TOLS)
