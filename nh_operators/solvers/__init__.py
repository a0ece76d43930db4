"""Solvers: correct classical integrators of Hamilton's equations, in float64.

Fixed-step RK4 and Yoshida methods on an exact potential or on the sensors' spline, the
paper's RK4 row, the adaptive reference solve used for truth, the resolution checks, and
the adaptive classical solve to a tolerance (q' = p, p' = −V'(q) from (q0, p0) on
[0, 1]). An error about one row of a batch is a :class:`~.row_error.RowError`.

Why a wing of its own: the networks are measured against these solvers, and ``solve``
falls back to them, so they are correct first (the step doubling's estimate bounds the
error; a step too coarse warns) and fast second. Imports :mod:`nh_operators.potentials`.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "classical_solve": ["RESOLVED_STEP", "ClassicalSolution", "adaptive_solve", "coerce_potential",
                        "solve_classical"],
    "collocation": ["Collocation", "chebyshev_points", "collocate", "collocation_residual",
                    "newton_collocation"],
    "fixed_step": ["integrate", "integrate_sensors", "paper_rk4", "sensor_spline_params"],
    "periodic": ["DIRECT_HORIZON", "PERIODIC_FROM", "HorizonPlan", "PeriodError", "PeriodShift"],
    "reference": ["reference_solve"],
    "resolution": ["ENERGY_DRIFT_TOL", "RESOLUTION_FRACTION", "STABILITY_LIMITS",
                   "ResolutionWarning", "check_energy", "check_formula", "check_resolution_of",
                   "spline_curvature", "spline_drift"],
    "row_error": ["RowError", "about_row"],
    "rows": ["RowSolution", "RowSource", "row_source", "solve_rows"],
    "schemes": ["MAX_STEPS", "METHODS", "ORDERS"],
    "level_grid": ["DEEP_GAPS", "KINK_SAFETY", "LevelGrid", "estimate_rule", "level_grid"],
    "start_level": ["COARSEST_START_TOL", "COARSER_START_TOL", "COARSE_START_TOL",
                    "START_TOLS", "start_coarseness", "start_levels"],
    "start_envelope": ["BARRIER_MARGIN", "KINETIC_MAX", "SAMPLES", "TURNING_FORCE",
                       "INSIDE", "PAST_GUARD", "inside_envelope", "orbit_flags", "row_flags"],
    "states": ["STATE_ATOL", "STATE_UNIFORMS", "check_states", "energy_states", "random_states",
               "state_arrays"],
})
