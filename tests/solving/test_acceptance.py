"""Reading a calibration by input kind (exact potentials, sensor values) and horizon."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.solving import (
    SENSOR_FAMILIES,
    acceptance_rate,
    bin_factors,
    calibrated,
    cautious_acceptance_rate,
)

PROBABILITIES = [0.0, 0.5, 1.0]


def _family(bounds, counts, quantiles):
    return {"bins": [{"n": n, "bound": b} if n else {"n": 0} for b, n in zip(bounds, counts)],
            "estimate_quantiles": quantiles}


def _calibration(sensors=True):
    families = {
        "in distribution": _family([20.0, 1.0, 1.0], [10, 5, 5], [1e-6, 1e-4, 1e-2]),
        "other distribution": _family([9.0, 1.0, 0.0], [10, 5, 0], [1e-5, 1e-3, 1e-1]),
        "out of distribution": _family([1.0, 1.0, 1.0], [1, 1, 1], [1e-5, 1e-3, 1e-1]),
        "sensors": _family([0.7, 0.1, 0.1], [10, 5, 5], [1e-7, 1e-5, 1e-3]),
    }
    cal = {"limits": [1e-3, 1e-2], "factors": [20.0, 20.0, 20.0], "factor": 20.0,
           "probabilities": PROBABILITIES, "estimate_quantiles": [1e-6, 1e-4, 1e-2],
           "families": families}
    if sensors:
        families[SENSOR_FAMILIES["other distribution"]] = _family(
            [1.8, 0.2, 0.0], [10, 2, 0], [1e-6, 1e-4, 1e-2])
        families[SENSOR_FAMILIES["out of distribution"]] = _family(
            [1.2, 0.9, 0.9], [3, 3, 3], [1e-6, 1e-4, 1e-2])
        cal["factors_sensors"] = bin_factors(families[f] for f in SENSOR_FAMILIES.values())
    return cal


def test_bin_factors_take_each_bins_largest_bound_and_never_fall():
    cal = _calibration()
    exact = [cal["families"][f] for f in SENSOR_FAMILIES]
    assert bin_factors(exact) == [20.0, 20.0, 20.0]
    # sensor bins: 1.8 (other), 0.9 (ood), 0.9; never below the first bin's 1.8
    assert cal["factors_sensors"] == [1.8, 1.8, 1.8]
    # a bin no family reached takes the largest bound of all
    lone = [_family([0.5, 3.0, 0.0], [4, 1, 0], [])]
    assert bin_factors(lone) == [0.5, 3.0, 3.0]
    assert bin_factors([]) is None and bin_factors([_family([0, 0, 0], [0, 0, 0], [])]) is None


def test_sensor_values_get_the_sensor_factors_where_calibrated():
    cal, raw = _calibration(), np.array([1e-4, 5e-3, 0.1])
    np.testing.assert_allclose(calibrated(raw, cal), 20.0 * raw)
    np.testing.assert_allclose(calibrated(raw, cal, "sensors"), 1.8 * raw)
    older = _calibration(sensors=False)  # an older file: one set of factors for both
    np.testing.assert_allclose(calibrated(raw, older, "sensors"), 20.0 * raw)
    np.testing.assert_allclose(calibrated(raw, None, "sensors"), raw)
    with pytest.raises(ValueError, match="kind must be 'exact' or 'sensors'"):
        calibrated(raw, cal, "bspline")


def test_the_share_a_kind_counts_on_reads_its_own_families():
    cal, tol = _calibration(), 1e-4
    assert acceptance_rate(cal, tol) == pytest.approx(0.5)  # in distribution, exact
    assert acceptance_rate(cal, tol, kind="sensors") == pytest.approx(0.75)  # "sensors"
    # one call counts on the smaller share of its own and the other generator's
    assert cautious_acceptance_rate(cal, tol) == pytest.approx(0.25)
    assert cautious_acceptance_rate(cal, tol, "sensors") == pytest.approx(0.5)
    older = _calibration(sensors=False)
    assert acceptance_rate(older, tol, kind="sensors") == acceptance_rate(older, tol)
    assert cautious_acceptance_rate(older, tol, "sensors") == pytest.approx(0.25)


@pytest.mark.parametrize("times, key", [([0.05, 0.3], "factors_sensors_early"),
                                        ([0.3, 1.5], "factors_sensors")])
def test_a_call_is_estimated_with_the_factors_of_its_horizon(times, key):
    """A call whose latest time is at most EARLY_HORIZON gets the early factors."""
    from nh_operators.solving import auto_solve
    from nh_operators.solving.acceptance import EARLY_HORIZON

    assert (max(times) <= EARLY_HORIZON) == key.endswith("_early")
    V, name, t = 8 * (nh.SENSORS - 0.5) ** 2, "phaseonet-paper", np.array(times)
    cal = auto_solve._model(name).calibration
    *_, raw = auto_solve.neural_raw(name, V, "sensors", t)
    *_, estimate = auto_solve.neural_solve(name, V, "sensors", t)
    factor = cal[key][int(np.searchsorted(cal["limits"], raw))]
    assert estimate == pytest.approx(factor * raw, rel=1e-12)
