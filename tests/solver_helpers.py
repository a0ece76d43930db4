"""Shared helpers of the solver tests (their fixtures live in conftest.py)."""

from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp


def l_tot(q, p, q_ref, p_ref):
    """The paper's per-sample loss (DESIGN §2): (mean (q - q̂)² + mean (p - p̂)²) / 2."""
    return 0.5 * (np.mean((q - q_ref) ** 2, axis=-1) + np.mean((p - p_ref) ** 2, axis=-1))


def max_error(q, p, q_ref, p_ref):
    return np.max(np.abs(q - q_ref)) + np.max(np.abs(p - p_ref))


def fitted_order(substeps, errors):
    """Slope of log(error) against log(h), h ∝ 1 / substeps (least squares)."""
    return np.polyfit(-np.log(np.asarray(substeps, float)), np.log(errors), 1)[0]


def dop853(force, t, rtol=1e-13, atol=1e-13):
    """Independent solve of q' = p, p' = force(q) from rest at 0 (scipy DOP853)."""
    sol = solve_ivp(lambda _, y: (y[1], force(y[0])), (0.0, float(np.max(t))), (0.0, 0.0),
                    method="DOP853", t_eval=t, rtol=rtol, atol=atol)
    assert sol.success
    return sol.y[0], sol.y[1]


def generator_sensor_values():
    """Sensor values of generator potentials: the test set when one is kept in /work/runs,
    else 500 drawn with its seed (42)."""
    import nh_operators as nh

    runs = Path("/work/runs")
    if (runs / "test.h5").exists():
        return nh.load_dataset(runs / "test.h5").V
    space = nh.BoundedPotentialSpace(seed=42)
    return nh.BoundedPotentialSpace.potentials(space.random(500)).V(nh.SENSORS)
