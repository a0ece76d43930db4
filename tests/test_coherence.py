"""Public functions accept what their neighbours return (across the wings).

Each test hands one function's output to the next, as a user would, and checks that the
answer equals the one the documented input gives, or that the error says what to call
instead.
"""

import warnings

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.models import as_network


@pytest.fixture(scope="module")
def shipped():
    return nh.pretrained("deeponet")


@pytest.fixture(scope="module")
def batch():
    space = nh.BoundedPotentialSpace(seed=5)
    return space.potentials(space.random(3))


def test_predict_takes_what_pretrained_returns(shipped):
    V = nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS)
    q, p = nh.predict(shipped, V[None], nh.TIMES)
    q_net, p_net = nh.predict(shipped.net, V[None], nh.TIMES)
    q_call, p_call = shipped(V[None], nh.TIMES)
    assert np.array_equal(q, q_net) and np.array_equal(p, p_net)
    assert np.array_equal(q, q_call) and np.array_equal(p, p_call)


def test_sensor_functions_take_potential_objects(shipped, batch):
    V = batch.V(nh.SENSORS)
    assert V.shape == (3, 100)
    for a, b in zip(nh.predict(shipped, batch, nh.TIMES), nh.predict(shipped, V, nh.TIMES)):
        assert np.array_equal(a, b)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", nh.ResolutionWarning)
        for a, b in zip(nh.integrate_sensors(batch, nh.TIMES, substeps=2),
                        nh.integrate_sensors(V, nh.TIMES, substeps=2)):
            assert np.array_equal(a, b)
    sho = nh.PHYSICAL_POTENTIALS["sho"]
    q, _ = nh.CLASSICAL_METHODS["rk4_sensors_4"](sho, nh.TIMES)
    assert abs(q[50] - sho.exact(nh.TIMES)[0][50]) < 1e-5  # the exact SHO, from its sensors
    assert nh.domain_violations(batch) == nh.domain_violations(V) == []


def test_neural_method_wraps_a_method_and_keeps_its_name(shipped):
    again = nh.NeuralMethod(shipped)
    assert again.net is shipped.net and again.name == "deeponet-alg1"
    assert as_network(again) is shipped.net


def test_solve_takes_the_object_pretrained_returns(shipped):
    by_object = nh.solve("sho", nh.TIMES, method=shipped)
    by_name = nh.solve("sho", nh.TIMES, method="deeponet")
    assert by_object.method == "deeponet-alg1" and by_object.kind == "neural"
    assert np.array_equal(by_object.q, by_name.q)
    assert by_object.error_estimate == by_name.error_estimate


def test_solve_refuses_an_uncalibrated_network_and_says_what_to_call(shipped):
    mine = nh.NeuralMethod(nh.build_model("deeponet", preset="cpu"), "mine")
    with pytest.raises(ValueError, match=r"calibrated network.*nh.predict\(net, V, t\)"):
        nh.solve("sho", [0.5], method=mine)


def test_a_batch_given_to_solve_says_how_to_index_it(batch):
    with pytest.raises(ValueError, match=r"got a batch of 3; index it with \[i\]"):
        nh.solve(batch, [0.5])
    sol = nh.solve(batch[1], [0.5], tol=1e-8)
    q, _ = nh.reference_solve(batch[1], [0.5])
    assert abs(sol.q[0] - q) < 1e-6


def test_the_pair_load_model_returns_is_refused_with_the_unpacking(shipped, tmp_path):
    with pytest.raises(TypeError, match=r"net, config = nh.load_model\(run_dir\)"):
        nh.predict((shipped.net, {}), np.zeros(100), nh.TIMES)
    with pytest.raises(TypeError, match="torch.nn.Module"):
        nh.predict("deeponet", np.zeros(100), nh.TIMES)


def test_operator_data_points_a_dataset_to_its_method():
    ds = nh.generate_dataset(12, seed=4, progress=False)
    with pytest.raises(TypeError, match=r"ds.to_deepxde\(\)"):
        nh.OperatorData(ds)
    data = ds.to_deepxde()
    assert isinstance(data, nh.OperatorData)
    assert data.train_x[0].shape[1] == 100


def test_complex_sensor_values_are_refused():
    with pytest.raises(TypeError, match="complex"):
        nh.domain_violations(np.zeros(100, dtype=complex))
