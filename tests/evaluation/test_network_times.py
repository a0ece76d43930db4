"""A network called directly makes the checks solve makes: its times stay in [0, 2]."""

import numpy as np
import pytest

import nh_operators as nh


@pytest.fixture(scope="module")
def model():
    return nh.pretrained("deeponet")


@pytest.mark.parametrize("t, message", [
    ([5.0], r"deeponet-alg1 was trained on t ∈ \[0, 2\] and is not asked beyond it \(got t = 5\)"),
    ([1e300], r"\(got t = 1e\+300\)"),
    ([-1.0], "times must be finite and ≥ 0, got -1.0"),
    ([np.nan], "times must be finite and ≥ 0, got nan"),
])
def test_times_outside_the_training_range_are_refused(model, t, message):
    V = nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS)
    with pytest.raises(ValueError, match=message):
        model(V, t)


def test_extrapolation_is_explicit_and_the_grid_is_unchanged(model):
    V = nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS)
    q, _ = model(V, nh.TIMES)
    q_net, _ = nh.predict(model.net, V, nh.TIMES)
    np.testing.assert_array_equal(q, q_net)
    free = nh.NeuralMethod(model.net, "deeponet", domain_check=False)
    q5, p5 = free(V, [5.0])
    assert np.isfinite(q5).all() and np.isfinite(p5).all()
    with pytest.raises(ValueError, match="finite and ≥ 0"):
        free(V, [-0.5])
