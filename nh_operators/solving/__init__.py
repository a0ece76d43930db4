"""Solve: the cheapest method that meets a tolerance, and the shipped networks.

:func:`solve` with its a-posteriori estimate and calibration, the measured contract, and
the pretrained weights. Imports every wing below it.
"""

from .auto_solve import CALIBRATION, DEFAULT_TOL, Solution, solve
from .calibration import CLASSICAL_TOLS, calibrate_pretrained
from .contract import Case, contract_cases, measure_contract, network_estimates
from .estimate import (
    CALIBRATION_QUANTILE,
    calibrate,
    raw_estimate,
    residuals,
    spline_rows,
)
from .shipped import WEIGHTS, available_pretrained, export_pretrained, pretrained

__all__ = [
    "spline_rows",
    "residuals",
    "raw_estimate",
    "calibrate",
    "CALIBRATION_QUANTILE",
    "Solution",
    "solve",
    "DEFAULT_TOL",
    "CALIBRATION",
    "WEIGHTS",
    "available_pretrained",
    "pretrained",
    "export_pretrained",
    "calibrate_pretrained",
    "CLASSICAL_TOLS",
    "Case",
    "contract_cases",
    "measure_contract",
    "network_estimates",
]
