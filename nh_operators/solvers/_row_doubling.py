"""The substep doubling of one row, compiled: every level of a single solve in one call.

A single ``solve`` runs three to five levels, and :func:`~.rows._doubling` spends most
of its time between them (a dispatch, a parallel launch, a dozen array operations per
level), not in them. :func:`double_one_row` does the same levels with the same step
grids, stepper and gap, in the same order (so the answer, estimate, substeps and history
are bit for bit those of the Python loop: ``tests/solvers/test_row_doubling.py``), in one
compiled call per force (:func:`~nh_operators.potentials._spline_kernels.specialised`).
"""

from collections.abc import Callable
from typing import NamedTuple

import numba
import numpy as np

from ..potentials._spline_kernels import FORCE, specialised
from ._kernels import grid_step, grid_steps, row_gap, trajectory_fixed
from .schemes import MAX_STEPS

__all__ = ["HISTORY", "OneRow", "double_one_row"]

#: Room for levels in the history of one call: a start 4 levels coarse (``first`` 1/16)
#: doubles at most 16 times before any cap up to 4,096 substeps.
HISTORY = 64


@numba.njit(inline="always")
def _maximum(a, b):
    """``np.maximum`` of two floats: NaN if either is."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a >= b else b


def _doubling_template(par, work, interval, first, q0, p0, solve_tol, rate, safety, deep,
                       max_substeps, weight, rk4, weights, back, q_a, p_a, q_b, p_b,
                       hist):
    """Levels 1, 2, 4, ... (× ``first``) of one row until its estimate meets
    ``solve_tol`` or the next level would pass ``max_substeps``.

    ``back`` (DEEP_GAPS - 1,) starts at inf; ``q_a`` ... ``p_b`` (W,) scratch; ``hist``
    (HISTORY, 2) gets (substeps, estimate) per level. Returns (levels, which of the
    scratch pairs holds the answer (0: a, 1: b), capped and not done), or
    (−substeps, 0, False) when that level's grid would exceed ``MAX_STEPS`` (the caller
    raises the grid's own message).
    """
    t_max = work[work.shape[0] - 1]
    level = 0
    newer = 1  # no level yet: level 1 goes into q_a
    substeps = 1
    while True:
        steps = grid_steps(t_max, substeps, interval)
        if steps > MAX_STEPS:
            return -substeps, 0, False
        h, nsteps = grid_step(t_max, steps)
        if newer == 0:
            qo, po, qn, pn = q_a, p_a, q_b, p_b
        else:
            qo, po, qn, pn = q_b, p_b, q_a, p_a
        trajectory_fixed(FORCE, par, work, h, nsteps, rk4, weights, qn, pn, q0, p0)
        newer = 1 - newer
        if substeps == 1:  # level 1: nothing to compare yet
            substeps = 2
            continue
        raw = row_gap(qo, po, qn, pn, weight)
        estimate = _maximum(raw, back[0] / rate)
        if deep:
            most = back[0]
            for k in range(1, back.shape[0]):
                most = _maximum(most, back[k])
            estimate = _maximum(estimate, most)
        estimate = estimate * safety
        hist[level, 0] = substeps * first
        hist[level, 1] = estimate
        level += 1
        done = estimate <= solve_tol
        # a full history counts as the cap (``ONE_ROW_CAP`` keeps it out of reach)
        capped = 2 * substeps * first > max_substeps or level == hist.shape[0]
        for k in range(back.shape[0] - 1, 0, -1):
            back[k] = back[k - 1]
        back[0] = raw
        if done or capped:
            return level, newer, capped and not done
        substeps *= 2


#: The compiled template per force (the lookup in :func:`specialised` hashes its key).
_KERNELS: dict = {}


class OneRow(NamedTuple):
    """What :func:`double_one_row` accepted: q, p (W,) at the working times, the
    substeps per output interval (× first), the estimate, the history
    [(substeps, estimate)] per level, and whether the cap came before tol."""

    q: np.ndarray
    p: np.ndarray
    substeps: int
    estimate: float
    history: list[tuple[int, float]]
    short: bool


def double_one_row(force, par, work, interval, first, q0, p0, solve_tol, rate, safety,
                   deep, max_substeps, weight, rk4, weights, deep_gaps,
                   too_many: Callable[[int], object]) -> OneRow:
    """The doubling of one row on its shared grid (see :func:`~.rows._doubling`).

    Args:
        force: the compiled force of the row's source; par: its (P,) parameters.
        work: (W,) sorted working times; interval: the output interval over ``first``.
        first: the substeps per output interval of level 1.
        q0, p0: the starting state; solve_tol: the target of the estimate.
        rate, safety, deep: the row's estimate rule (:class:`~.level_grid.LevelGrid`).
        max_substeps: the cap; weight: (W,) the gap's weights.
        rk4, weights: the stepper (:func:`~.schemes.step_method`).
        deep_gaps: :data:`~.level_grid.DEEP_GAPS`.
        too_many: called with a level's substeps when its grid would take more than
            ``MAX_STEPS`` steps, before that level runs; it raises the grid's message.

    Returns:
        :class:`OneRow`.

    Raises:
        what ``too_many`` raises (a ``RuntimeError`` if it returns).
    """
    w = work.shape[0]
    scratch = np.empty((4, w))
    hist = np.empty((HISTORY, 2))
    back = np.full(deep_gaps - 1, np.inf)
    kernel = _KERNELS.get(force)
    if kernel is None:
        kernel = _KERNELS[force] = specialised(_doubling_template, {"FORCE": force})
    levels, newer, short = kernel(par, work, interval, first, q0, p0, solve_tol, rate,
                                  safety, deep, max_substeps, weight, rk4, weights, back,
                                  scratch[0], scratch[1], scratch[2], scratch[3], hist)
    if levels < 0:
        too_many(-levels)
        raise RuntimeError(f"a level of {-levels} substeps exceeds MAX_STEPS")
    q, p = (scratch[0], scratch[1]) if newer == 0 else (scratch[2], scratch[3])
    history = list(zip(hist[:levels, 0].astype(np.int64).tolist(),
                       hist[:levels, 1].tolist(), strict=True))
    return OneRow(q, p, history[-1][0], history[-1][1], history, bool(short))

