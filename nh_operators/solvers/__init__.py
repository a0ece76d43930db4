"""Solvers: correct classical integrators of Hamilton's equations, in float64.

Fixed-step RK4 and Yoshida methods on an exact potential or on the sensors' spline, the
paper's RK4 row, the adaptive reference solve used for truth, the resolution checks, and
the adaptive classical solve to a tolerance. Imports :mod:`nh_operators.potentials`.
"""

from .classical_solve import SAFETY, ClassicalSolution, adaptive_solve, solve_classical
from .fixed_step import integrate, integrate_sensors, paper_rk4, sensor_spline_params
from .reference import reference_solve
from .resolution import (
    ENERGY_DRIFT_TOL,
    RESOLUTION_FRACTION,
    STABILITY_LIMITS,
    ResolutionWarning,
    check_energy,
    check_formula,
    check_resolution_of,
    spline_curvature,
    spline_drift,
)
from .schemes import METHODS, ORDERS

__all__ = [
    "METHODS",
    "ORDERS",
    "ResolutionWarning",
    "STABILITY_LIMITS",
    "RESOLUTION_FRACTION",
    "ENERGY_DRIFT_TOL",
    "check_resolution_of",
    "check_energy",
    "check_formula",
    "spline_curvature",
    "spline_drift",
    "integrate",
    "integrate_sensors",
    "paper_rk4",
    "sensor_spline_params",
    "reference_solve",
    "ClassicalSolution",
    "solve_classical",
    "adaptive_solve",
    "SAFETY",
]
