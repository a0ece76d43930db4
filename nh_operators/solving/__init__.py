"""Solve: the cheapest method that meets a tolerance, and the shipped networks.

:func:`solve` with its a-posteriori estimate and calibration, the measured contract, and
the pretrained weights. Imports every wing below it.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "auto_solve": ["DEFAULT_TOL", "Solution", "solve"],
    "calibration": ["CLASSICAL_TOLS", "LIMITS", "calibrate_pretrained"],
    "samples": ["SENSOR_PASSES", "calibration_families"],
    "refine": ["FINE_TIMES", "REFINE", "fine_estimate", "refines"],
    "contract": ["Case", "contract_cases", "measure_contract", "network_estimates"],
    "costs": ["SHORT_HORIZON", "horizon_share"],
    "acceptance": ["EARLY_HORIZON", "SENSOR_FAMILIES", "acceptance_rate", "bin_factors",
                   "calibrated", "cautious_acceptance_rate", "upper_quantile"],
    "estimate": ["CALIBRATION_QUANTILE", "calibrate", "estimate_at",
                 "propagated_error", "raw_estimate", "residuals", "spline_rows"],
    "many": ["ManySolution", "solve_many"],
    "catalog": ["CALIBRATION", "DOMAIN", "WEIGHTS", "available_pretrained", "network_domain",
                "reads_state", "resolve_pretrained"],
    "shipped": ["export_pretrained", "pretrained", "refit_domain"],
    "preload": ["preload"],
})
