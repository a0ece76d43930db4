"""The fixed-step schemes: classical RK4 and symplectic Yoshida compositions.

Their step weights, convergence orders, and the step grid that covers the query times
(shared by the solvers and by the resolution checks of :mod:`.resolution`).
"""

import numpy as np

from .._constants import TIMES

__all__ = ["METHODS", "ORDERS", "MAX_STEPS"]

#: A fixed-step solve refuses to take more steps than this (about a minute of one
#: core): far horizons are for :func:`~nh_operators.solve`, which answers from one period.
MAX_STEPS = 2e8


def _triple_jump(weights, order):
    """Yoshida's triple jump: a method of even order ``order`` from one of order - 2."""
    root = 2.0 ** (1.0 / (order - 1))
    w1 = 1.0 / (2.0 - root)
    w0 = -root * w1
    return np.concatenate([w1 * weights, w0 * weights, w1 * weights])


_VERLET = np.array([1.0])
_Y4 = _triple_jump(_VERLET, 4)
_Y6 = _triple_jump(_Y4, 6)
_Y8 = _triple_jump(_Y6, 8)

#: Step methods: None means classical RK4; otherwise the Störmer–Verlet sub-step weights
#: of a symplectic composition (Yoshida's triple jump for orders 4, 6 and 8).
METHODS = {"rk4": None, "verlet": _VERLET, "yoshida4": _Y4, "yoshida6": _Y6, "yoshida8": _Y8}
#: Convergence order of each method on smooth potentials.
ORDERS = {"rk4": 4, "verlet": 2, "yoshida4": 4, "yoshida6": 6, "yoshida8": 8}


def check_times(t):
    """The query times as a float64 vector, or a ValueError naming what is wrong.

    Args:
        t: times, (M,) or (M, 1), finite and ≥ 0.

    Returns:
        (M,) float64 array.

    Raises:
        ValueError: empty, not 1-D, or holding a negative or non-finite time.

    Example:
        >>> check_times([[0.0], [0.5]]).tolist()
        [0.0, 0.5]
    """
    t = np.asarray(t, dtype=np.float64)
    if t.ndim == 2 and t.shape[1] == 1:
        t = t[:, 0]
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"t must be a non-empty 1-D array of times, got shape {t.shape}")
    if not np.all(np.isfinite(t)) or np.any(t < 0):
        raise ValueError("t must hold finite times ≥ 0 (the particle starts at t = 0)")
    return t


def step_grid(t, substeps, interval):
    """Sorted query times, step size and number of steps covering [0, max t].

    Args:
        t: (M,) float64 query times (see :func:`check_times`).
        substeps: steps per ``interval`` (a positive integer).
        interval: the spacing the steps refine; None: that of ``t`` when it is a uniform
            grid from 0, else that of :data:`TIMES`.

    Returns:
        (order (M,) indices sorting ``t``, ts (M,) sorted times, h step size, nsteps).

    Raises:
        ValueError: a bad ``substeps`` or ``interval``, or more than :data:`MAX_STEPS`
            steps.

    Example:
        >>> order, ts, h, nsteps = step_grid(np.array([1.0, 0.0, 0.5]), 2, None)
        >>> order.tolist(), float(h), nsteps
        ([1, 2, 0], 0.25, 4)
    """
    if not (isinstance(substeps, (int, np.integer)) and substeps >= 1):
        raise ValueError(f"substeps must be a positive integer, got {substeps}")
    order = np.argsort(t, kind="stable")
    ts = np.ascontiguousarray(t[order])
    if interval is None:
        interval = TIMES[1] - TIMES[0]
        if ts.size >= 2 and ts[0] == 0.0:
            gaps = np.diff(ts)
            if gaps[0] > 0 and np.abs(gaps - gaps[0]).max() <= 1e-9 * gaps[0]:
                interval = gaps[0]
    if not interval > 0:
        raise ValueError(f"interval must be positive, got {interval}")
    t_max = ts[-1]
    steps = t_max * substeps / interval - 1e-9
    if steps > MAX_STEPS:
        raise ValueError(f"t = {t_max:g} needs {steps:.3g} fixed steps at {substeps} "
                         f"substep(s), more than {MAX_STEPS:g}; nh.solve answers any horizon "
                         "from one period of the orbit")
    nsteps = int(np.ceil(steps)) if t_max > 0 else 0
    h = t_max / nsteps if nsteps else 1.0
    return order, ts, h, nsteps


def step_method(method):
    """How a method steps: (classical RK4?, its Störmer–Verlet sub-step weights).

    Args:
        method: a key of :data:`METHODS`.

    Returns:
        (rk4 bool, weights (S,) float64; Verlet's ``[1.0]`` for RK4, unused there).

    Raises:
        ValueError: an unknown method.

    Example:
        >>> step_method("verlet")[0], step_method("yoshida4")[1].shape
        (False, (3,))
    """
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; choose one of {sorted(METHODS)}")
    weights = METHODS[method]
    return weights is None, (_VERLET if weights is None else weights)
