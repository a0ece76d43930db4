"""Solve: the cheapest method that meets a tolerance, and the shipped networks.

The entry points (:func:`solve`, :func:`solve_many`) on top; under them one loader of
shipped networks (:func:`load`, a :class:`ShippedNetwork` each) and one typed
:class:`Calibration` per network. Imports every wing below it.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "auto_solve": ["DEFAULT_TOL", "Solution", "solve"],
    "many": ["ManySolution", "solve_many"],
    "answers": ["Candidate", "Truth", "Verdict"],
    "loader": ["ShippedNetwork", "load"],
    "calibration": ["Calibration"],
    "kinds": ["CallKind", "InputKind"],
    "calibrate": ["Measure", "calibrate_factors", "calibrate_pretrained", "measure_costs"],
    "refine": ["FINE_TIMES", "REFINE", "fine_estimate", "refines"],
    "contract": ["Case", "contract_cases", "measure_contract", "network_estimates"],
    "acceptance": ["EARLY_HORIZON"],
    "estimate": ["estimate_at", "propagated_error", "raw_estimate", "residuals",
                 "spline_rows"],
    "catalog": ["CALIBRATION", "DOMAIN", "WEIGHTS", "available_pretrained", "network_domain",
                "reads_state", "resolve_pretrained"],
    "shipped": ["export_pretrained", "pretrained", "refit_domain"],
    "preload": ["preload"],
})
