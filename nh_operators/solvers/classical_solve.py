"""A classical solve to a tolerance: only the times asked for, substeps doubled until met.

:func:`solve_classical` integrates Hamilton's equations for one potential given as a
name, a text expression, a callable (with or without its derivative), a
:class:`BoundedPotential` or 100 sensor values, and doubles the substeps until an error
estimate of L_tot at the requested times is below ``tol``.

**Error estimate.** With solutions y_k and y_2k at k and 2k substeps, the estimate for
y_2k is L_tot(y_2k − y_k). For a method of order p on a smooth potential the true error
of y_2k is about (2^p − 1)² times smaller (225× for RK4), and across a kink (order 1)
about the same: the estimate errs on the safe side for every order ≥ 1 — once the
errors shrink with the step. Before that, two coarse solutions can be wrong alike and
agree (a generator potential of the test set: L_tot 3e-4 and 5e-4 at 1 and 2 RK4
substeps, 2e-5 apart). So a level is accepted only when its estimate is below ``tol``
*and*, from the second level on, below the previous level's estimate: the differences
have started to shrink.
Even then the estimate can be low by more than 10× (one test-set potential in a
thousand: 3e-9 estimated, 5e-8 true), so a level must reach ``SAFETY · tol``; except
where successive estimates shrink by less than 16× (first-order convergence, as across
a kink, where the difference itself bounds the error), which need ``tol / 4``.
"""

import time
from dataclasses import dataclass, field

import numpy as np

from .._backend import single_threaded
from .._metrics import loss_per_sample
from ..potentials.coerce import as_potential
from .fixed_step import integrate, integrate_sensors
from .schemes import ORDERS

__all__ = ["ClassicalSolution", "solve_classical", "adaptive_solve", "SAFETY"]

#: A level is accepted when its estimate is below SAFETY · tol (see above).
SAFETY = 0.01


@dataclass
class ClassicalSolution:
    """What :func:`solve_classical` returns.

    Attributes:
        q, p: float64 arrays (M,) at the requested times, in their order.
        method: the integrator, e.g. ``"rk4"``.
        substeps: steps per output interval of the returned solution.
        error_estimate: the L_tot estimate described in the module docstring.
        seconds: wall time of the whole solve.
        information: ``"exact V"`` or ``"sensors"`` (then the truth is the spline of
            the sensors, and the distance to any other potential with the same sensor
            values is not part of the estimate).
        history: (substeps, estimate) of every level tried.
    """

    q: np.ndarray
    p: np.ndarray
    method: str
    substeps: int
    error_estimate: float
    seconds: float
    information: str
    history: list = field(default_factory=list)


def _run(pot, information, t, method, substeps):
    if information == "sensors":
        return integrate_sensors(pot, t, method, substeps, check_resolution=False)
    return integrate(pot, t, method, substeps, check_resolution=False)


def solve_classical(potential, t, *, tol=1e-8, method="rk4", dV=None, max_substeps=4096):
    """Solve at exactly the times ``t`` to an estimated L_tot ≤ ``tol``.

    Args:
        potential: see :func:`~nh_operators.potentials.as_potential`.
        t: query times, any order, ≥ 0.
        tol: target L_tot (mean over the times of the squared errors of q and p,
            averaged); > 0.
        method: a key of :data:`~nh_operators.METHODS`.
        dV: derivative of a callable V.
        max_substeps: give up (with a warning) beyond this many steps per interval.

    Returns:
        :class:`ClassicalSolution`.

    Raises:
        ValueError: for a bad potential, times, method or tolerance.

    Example:
        >>> sol = solve_classical("sho", [0.5, 1.0], tol=1e-10)
        >>> sol.error_estimate <= 1e-10, round(float(sol.q[0]), 6)
        (True, 0.708073)
    """
    start = time.perf_counter()
    if not (isinstance(tol, (int, float)) and tol > 0):
        raise ValueError(f"tol must be a positive number, got {tol!r}")
    if method not in ORDERS:
        raise ValueError(f"unknown method {method!r}; choose one of {sorted(ORDERS)}")
    with single_threaded():
        pot, information = as_potential(potential, dV)
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    return adaptive_solve(pot, information, t, tol, method, max_substeps, start)


def adaptive_solve(pot, information, t, tol, method, max_substeps=4096, start=None):
    """The doubling loop of :func:`solve_classical` on an already checked potential
    (the output of :func:`~nh_operators.potentials.as_potential`); ``start`` is the perf_counter at which the
    solve's clock started (default: now). Runs on one thread
    (:func:`~nh_operators._backend.single_threaded`)."""
    start = time.perf_counter() if start is None else start
    with single_threaded():
        return _doubling(pot, information, t, tol, method, max_substeps, start)


def _doubling(pot, information, t, tol, method, max_substeps, start):
    import warnings

    substeps = 1
    q, p = _run(pot, information, t, method, substeps)
    history = []
    previous = np.inf
    while True:
        q2, p2 = _run(pot, information, t, method, 2 * substeps)
        estimate = float(loss_per_sample(q2, p2, q, p)["L_tot"])
        substeps *= 2
        history.append((substeps, estimate))
        q, p = q2, p2
        ratio = previous / estimate if estimate > 0 else np.inf
        low_order = 1.5 < ratio < 16.0  # about first order: the difference bounds the error
        if estimate == 0.0 or (ratio > 1.0 and estimate <= (0.25 if low_order else SAFETY) * tol):
            break
        previous = estimate
        if 2 * substeps > max_substeps:
            warnings.warn(f"tolerance {tol:g} not reached within {max_substeps} substeps "
                          f"(estimate {estimate:.3g}); returning the finest solution",
                          RuntimeWarning, stacklevel=5)
            break
    return ClassicalSolution(q, p, method, substeps, estimate, time.perf_counter() - start,
                             information, history)
