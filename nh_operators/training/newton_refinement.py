"""Test-time refinement of a trajectory: Newton's method on Hamilton's equations from a
network's prediction.

What: :func:`refine_newton` (``nh.refine(..., method="newton")``) takes a network's
prediction on one potential as the first guess of a Chebyshev collocation solve
(:func:`~nh_operators.solvers.collocate`) and returns the trajectory that solves
dq/dt = p, dp/dt = −V'(q) to a tolerance, with the collocation's own error estimate.

The math: the network runs once on its 100-point grid; its q is carried to the
Chebyshev points by a cubic spline; Newton's method then drives the collocation residual
to rounding, and the number of points doubles until the last Chebyshev coefficients are
below ``tol``. V' is the potential's own derivative when it has one (``dV``; V'' by a
central difference of it, which only steers Newton's steps), else the not-a-knot spline
of the sensor values (or of ``knots`` samples of ``V``).

Why: lowering the residual through the network's weights (``method="weights"``) pins the
trajectory poorly and costs seconds; the network is far better used as the guess that
Newton's method needs on an oscillating horizon. A global polynomial needs a smooth
force: for a kinked potential (MFF) it does not converge, and says so (``converged``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np
import torch
from scipy.interpolate import CubicSpline

from .._constants import SENSORS, TIMES
from ..models import batched_forward
from ..solvers import collocate, collocation_residual
from .refinement_result import Refinement

__all__ = ["refine_newton"]


def refine_newton(model: Any, potential: Any, t: np.ndarray = TIMES, *, tol: float = 1e-10,
                  q0: float = 0.0, p0: float = 0.0, n_start: int = 32, n_max: int = 512,
                  knots: int = 1000) -> Refinement:
    """Refine a network's prediction on one potential by Newton collocation.

    Args:
        model: any network of the package (pointwise or not), or a method holding one in
            ``.net`` (``nh.pretrained(name)``).
        potential: 100 sensor values, or an object with vectorised ``V(q)`` and, ideally,
            ``dV(q)`` (the physical potentials, a :class:`~nh_operators.BoundedPotential`).
        t: (M,) times in [0, 2] to answer at.
        tol: accept when the trajectory's last Chebyshev coefficients are below it.
        q0, p0: the starting state (a network that reads a state gets them).
        n_start, n_max: the first and largest number of collocation intervals.
        knots: samples of a potential that has ``V`` but no ``dV`` (its spline).

    Returns:
        :class:`~nh_operators.training.Refinement` with ``net`` None, ``steps`` the Newton
        steps, ``estimate`` and ``converged`` from the collocation; the residuals are the
        mean squared residuals of the guess's and the answer's interpolants at the
        collocation points. When Newton's method did not converge and left a larger
        residual than the network's, the answer is the network's own (``converged``
        False, the residual unchanged).

    Raises:
        ValueError: for times outside [0, 2], a non-positive ``tol`` or bad values.

    Example:
        >>> import nh_operators as nh
        >>> r = refine_newton(nh.pretrained("deeponet-paper"), nh.PHYSICAL_POTENTIALS["sho"])
        >>> bool(r.converged), bool(r.estimate < 1e-10)
        (True, True)
    """
    start = time.perf_counter()
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    end = float(TIMES[-1])
    if t.size == 0 or not np.all(np.isfinite(t)) or t.min() < 0 or t.max() > end:
        raise ValueError(f"method='newton' answers at times in [0, {end:g}] (the network's "
                         f"horizon), got [{t.min() if t.size else 'none'}, "
                         f"{t.max() if t.size else 'none'}]")
    sensors, dV, d2V = _forces(potential, knots)
    q_net, p_net = _network_guess(model, sensors, q0, p0)
    guess = CubicSpline(TIMES, q_net)
    p_guess = CubicSpline(TIMES, p_net)
    sol = collocate(dV, d2V, guess, end, q0, p0, tol=tol, n_start=n_start, n_max=n_max)
    before = collocation_residual(guess(sol.t), p_guess(sol.t), end, dV)
    after = collocation_residual(sol.q, sol.p, end, dV)
    if sol.converged or after < before:
        q, p = sol(t)
    else:  # Newton went astray: the network's answer stands, flagged not converged
        q, p, after = guess(t), p_guess(t), before
    return Refinement(q, p, before, after, sol.steps, time.perf_counter() - start, None,
                      estimate=sol.estimate, converged=sol.converged)


def _network_guess(model: Any, sensors: np.ndarray, q0: float, p0: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The network's (q, p) on its 100-point grid, float64."""
    net = getattr(model, "net", model)
    V = sensors[None]
    if getattr(net, "initial_state", False):
        V = np.concatenate([V, [[q0, p0]]], axis=1)
    with torch.no_grad():
        y = np.concatenate([o.double().numpy()
                            for _, o in batched_forward(net, V, TIMES[:, None], 1)])[0]
    return y[:, 0], y[:, 1]


def _forces(potential: Any, knots: int) -> tuple[np.ndarray, Callable, Callable]:
    """(sensor values, V', V'') of what was given."""
    if callable(getattr(potential, "V", None)):
        sensors = np.asarray(potential.V(SENSORS), dtype=np.float64).reshape(-1)
        if callable(getattr(potential, "dV", None)):
            def dV(q: np.ndarray) -> np.ndarray:
                return np.asarray(potential.dV(q), dtype=np.float64)

            def d2V(q: np.ndarray) -> np.ndarray:
                h = 1e-6
                return (dV(q + h) - dV(q - h)) / (2 * h)

            return _checked(sensors), dV, d2V
        grid = np.linspace(0.0, 1.0, knots)
        spline = CubicSpline(grid, np.asarray(potential.V(grid), dtype=np.float64))
    else:
        sensors = np.asarray(potential, dtype=np.float64).reshape(-1)
        spline = CubicSpline(SENSORS, _checked(sensors))
    first, second = spline.derivative(1), spline.derivative(2)
    return _checked(sensors), first, second


def _checked(sensors: np.ndarray) -> np.ndarray:
    if sensors.shape != SENSORS.shape or not np.all(np.isfinite(sensors)):
        raise ValueError(f"potential must be one potential: {SENSORS.size} finite sensor "
                         f"values or an object with V(q); got {sensors.size} values")
    return sensors
