"""Where the classical doubling starts: the resolved step, or coarser at loose tolerances
for rows inside the envelope where that was checked (issue 41, "a cheaper proof").

The doubling of :func:`~.rows.solve_rows` accepts a level only on evidence (the last two
gaps), so every level below the accepted one is work spent on the proof, and a coarser
first level makes the proof cheaper. Starting 1, 2 or 3 levels coarser from tol 1e-8,
1e-6 and 1e-3 up held on the families of ``benchmarks/promise/classical_estimate.py``
(generator potentials as curves and as sensor values, 20 out-of-distribution formulas per
draw), but not on 2,000 out-of-distribution potentials given as sensor values
(``benchmarks/promise/sensor_contract.py --seed 7001|7002|7003``): three coarse levels
agreed by chance on orbits that are slow somewhere (released where the force almost
vanishes, or passing a barrier top just below their energy), and answers missed tol by up
to 43×. So a row starts coarse only inside the envelope of :mod:`.start_envelope`, which
excludes such orbits; every other row starts at :data:`RESOLVED_STEP` (docs: solve,
"Coarse starts, per row").
"""

import numpy as np

from .._constants import TIMES
from .start_envelope import INSIDE, PAST_GUARD, row_flags

__all__ = ["COARSEST_START_TOL", "COARSER_START_TOL", "COARSE_START_TOL", "RESOLVED_STEP",
           "START_TOLS", "start_coarseness", "start_levels"]

#: The coarsest step the doubling starts from: 1/8 of the spacing of :data:`TIMES`
#: (:mod:`.classical_solve`). At the largest speed a generator potential gives (about 2.8)
#: it moves the particle 0.007 per step, less than the sensor spacing 1/99, so no level
#: used as evidence steps over the features of V.
RESOLVED_STEP = (TIMES[1] - TIMES[0]) / 8.0

#: The tols from which a row inside the envelope starts 1, 2, 3 levels coarser than
#: :data:`RESOLVED_STEP` (chosen on ``benchmarks/promise/classical_estimate.py``).
COARSE_START_TOL, COARSER_START_TOL, COARSEST_START_TOL = 1e-8, 1e-6, 1e-3
#: The thresholds :func:`start_coarseness` counts, read at call time; ``()`` starts every
#: row resolved.
START_TOLS: tuple[float, ...] = (COARSE_START_TOL, COARSER_START_TOL, COARSEST_START_TOL)


def start_coarseness(tol: float | np.ndarray) -> int | np.ndarray:
    """How many levels coarser than :data:`RESOLVED_STEP` a row solved to ``tol`` starts
    inside the envelope.

    Args:
        tol: a row's target L_tot, or an array of them.

    Returns:
        How many of :data:`START_TOLS` (read at call time) ``tol`` reaches: an int, or
        int64 of ``tol``'s shape.

    Example:
        >>> start_coarseness(1e-3), start_coarseness(1e-7), start_coarseness(1e-12)
        (3, 1, 0)
    """
    if isinstance(tol, float):
        return sum(tol >= start for start in START_TOLS)
    counts = (np.asarray(tol, dtype=np.float64)[..., None]
              >= np.asarray(START_TOLS, dtype=np.float64)).sum(-1)
    return int(counts) if counts.ndim == 0 else counts.astype(np.int64)


def start_levels(src, tols: np.ndarray, q0s: np.ndarray,
                 p0s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per row, how many levels coarser than :data:`RESOLVED_STEP` its doubling starts,
    and whether its orbit crosses a kink of the source.

    Args:
        src: a :class:`~.rows.RowSource`.
        tols, q0s, p0s: (N,) each row's target L_tot and starting state.

    Returns:
        coarse: (N,) int64, :func:`start_coarseness` of the row's tol inside the
            envelope (:func:`~.start_envelope.row_flags`), 0 outside it or kinked.
        kinked: (N,) bool, the row's orbit reaches past ``OUTSIDE_MARGIN`` of a source
            whose force is held there (``src.guarded``).
    """
    tols = np.asarray(tols, dtype=np.float64)
    if tols.size == 1:  # one row (a single solve): its count on a scalar, cheaper
        coarse = np.full(tols.shape, start_coarseness(float(tols.reshape(-1)[0])),
                         dtype=np.int64)
    else:
        coarse = np.asarray(start_coarseness(tols), dtype=np.int64).reshape(tols.shape)
    if not (src.guarded or coarse.any()):
        return coarse, np.zeros(tols.shape, dtype=bool)
    flags = row_flags(src, q0s, p0s)
    kinked = ((flags & PAST_GUARD) > 0) & bool(src.guarded)
    coarse[((flags & INSIDE) == 0) | kinked] = 0
    return coarse, kinked
