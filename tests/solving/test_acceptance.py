"""Reading a calibration by input kind (exact potentials, sensor values) and horizon."""

import numpy as np
import pytest
from calibration_helpers import fake_calibration

import nh_operators as nh
from nh_operators.solving import CallKind, InputKind
from nh_operators.solving.acceptance import SENSOR_FAMILIES, bin_factors
from nh_operators.solving.calibration import Calibration

PROBABILITIES = [0.0, 0.5, 1.0]


def _family(bounds, counts, quantiles):
    return {"bins": [{"n": n, "bound": b} if n else {"n": 0} for b, n in zip(bounds, counts)],
            "estimate_quantiles": quantiles}


def _calibration():
    families = {
        "in distribution": _family([20.0, 1.0, 1.0], [10, 5, 5], [1e-6, 1e-4, 1e-2]),
        "other distribution": _family([9.0, 1.0, 0.0], [10, 5, 0], [1e-5, 1e-3, 1e-1]),
        "out of distribution": _family([1.0, 1.0, 1.0], [1, 1, 1], [1e-5, 1e-3, 1e-1]),
        "sensors": _family([0.7, 0.1, 0.1], [10, 5, 5], [1e-7, 1e-5, 1e-3]),
    }
    families[SENSOR_FAMILIES["other distribution"]] = _family(
        [1.8, 0.2, 0.0], [10, 2, 0], [1e-6, 1e-4, 1e-2])
    families[SENSOR_FAMILIES["out of distribution"]] = _family(
        [1.2, 0.9, 0.9], [3, 3, 3], [1e-6, 1e-4, 1e-2])
    sensors = bin_factors(families[f] for f in SENSOR_FAMILIES.values())
    data = fake_calibration().to_json()
    data.update(factors={"exact": {"plain": [20.0, 20.0, 20.0]}, "sensors": {"plain": sensors}},
                probabilities=PROBABILITIES, estimate_quantiles=[1e-6, 1e-4, 1e-2],
                families=families)
    return Calibration.from_json(data)


def test_bin_factors_take_each_bins_largest_bound_and_never_fall():
    cal = _calibration()
    exact = [cal.families[f] for f in SENSOR_FAMILIES]
    assert bin_factors(exact) == [20.0, 20.0, 20.0]
    # sensor bins: 1.8 (other), 0.9 (ood), 0.9; never below the first bin's 1.8
    assert cal.factors[(InputKind.SENSORS, CallKind.PLAIN)].tolist() == [1.8, 1.8, 1.8]
    # a bin no family reached takes the largest bound of all
    lone = [_family([0.5, 3.0, 0.0], [4, 1, 0], [])]
    assert bin_factors(lone) == [0.5, 3.0, 3.0]
    assert bin_factors([]) is None and bin_factors([_family([0, 0, 0], [0, 0, 0], [])]) is None


def test_sensor_values_get_the_sensor_factors():
    cal, raw = _calibration(), np.array([1e-4, 5e-3, 0.1])
    np.testing.assert_allclose(cal.calibrated(raw, InputKind.BSPLINE), 20.0 * raw)
    np.testing.assert_allclose(cal.calibrated(raw, InputKind.FORMULA), 20.0 * raw)
    np.testing.assert_allclose(cal.calibrated(raw, InputKind.SENSORS), 1.8 * raw)
    # no factors for a kind of call (here: fine, early): never accepted
    assert np.isinf(cal.calibrated(raw, InputKind.SENSORS, CallKind.FINE)).all()
    with pytest.raises(ValueError, match="is not a valid InputKind"):
        cal.calibrated(raw, "exact V")


def test_the_share_a_kind_counts_on_reads_its_own_families():
    cal, tol = _calibration(), 1e-4
    assert cal.acceptance_rate(tol, InputKind.BSPLINE) == pytest.approx(0.5)  # in dist.
    assert cal.acceptance_rate(tol, InputKind.SENSORS) == pytest.approx(0.75)  # "sensors"
    assert cal.acceptance_rate(1e-7, InputKind.BSPLINE) == 0.0
    assert cal.acceptance_rate(1e-5, InputKind.BSPLINE) == pytest.approx(0.25)  # log interp
    assert cal.acceptance_rate(1.0, InputKind.BSPLINE) == 1.0
    # one call counts on the smaller share of its own and the other generator's
    assert cal.acceptance_rate(tol, InputKind.BSPLINE, cautious=True) == pytest.approx(0.25)
    assert cal.acceptance_rate(tol, InputKind.SENSORS, cautious=True) == pytest.approx(0.5)


def test_a_format_1_file_migrates_with_every_number_in_place():
    old = {"limits": [1e-3, 1e-2], "factor": 2.0, "factors": [2.0, 3.0, 8.0],
           "factors_early": [5.0, 5.0, 9.0], "factors_sensors": [0.5, 1.0, 4.0],
           "factors_sensors_early": [6.0, 6.0, 6.0], "probabilities": [0.0, 1.0],
           "estimate_quantiles": [1e-6, 1e-2], "families": {}, "quantile": 0.999,
           "neural_seconds": 1e-4, "neural_seconds_batched": 1e-5, "device": {"cpu": 2},
           "classical_tols": [1e-3, 1e-6], "classical_seconds": [1.0, 2.0],
           "classical_seconds_short": [0.5, 1.0], "classical_seconds_batched": [0.1, 0.2],
           "classical_seconds_sensors": [3.0, 4.0], "classical_seconds_sensors_short": [1, 2],
           "classical_seconds_sensors_batched": [0.3, 0.4],
           "classical_seconds_formula": [7.0, 8.0], "classical_seconds_formula_short": [3, 4]}
    cal = Calibration.from_json(old)
    assert cal.version == 1
    raw = np.array([1e-4, 5e-3, 0.1])
    np.testing.assert_array_equal(cal.calibrated(raw, InputKind.FORMULA, CallKind.EARLY),
                                  [5e-4, 2.5e-2, 0.9])
    np.testing.assert_array_equal(cal.calibrated(raw, InputKind.SENSORS), [5e-5, 5e-3, 0.4])
    assert cal.classical_seconds(1e-6, InputKind.SENSORS, batched=True) == 0.4
    assert cal.classical_seconds(1e-6, InputKind.FORMULA, batched=True) == 8.0
    assert cal.neural_seconds_per(True) == 1e-5 and cal.info["quantile"] == 0.999
    new = cal.to_json()
    assert new["format"] == 2 and new["factors"]["exact"]["early"] == [5.0, 5.0, 9.0]
    again = Calibration.from_json(new)
    assert again.version == 2 and again.to_json() == new
    with pytest.raises(ValueError, match="predates factors_sensors"):
        Calibration.from_json({k: v for k, v in old.items() if k != "factors_sensors"})
    with pytest.raises(ValueError, match="calibration format 3"):
        Calibration.from_json(dict(new, format=3))


@pytest.mark.parametrize("times, call", [([0.05, 0.3], CallKind.EARLY),
                                         ([0.3, 1.5], CallKind.PLAIN)])
def test_a_call_is_estimated_with_the_factors_of_its_horizon(times, call):
    """A call whose latest time is at most EARLY_HORIZON gets the early factors."""
    from nh_operators.solving.acceptance import EARLY_HORIZON
    from nh_operators.solving.loader import load
    from nh_operators.solving.network_pass import neural_raw, neural_solve

    assert (max(times) <= EARLY_HORIZON) == (call is CallKind.EARLY)
    V, name, t = 8 * (nh.SENSORS - 0.5) ** 2, "phaseonet-paper", np.array(times)
    cal = load(name).calibration
    *_, raw = neural_raw(name, V, "sensors", t)
    *_, estimate = neural_solve(name, V, "sensors", t)
    factor = cal.factors[(InputKind.SENSORS, call)][int(np.searchsorted(cal.limits, raw))]
    assert estimate == pytest.approx(factor * raw, rel=1e-12)
