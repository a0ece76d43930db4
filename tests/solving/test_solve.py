"""solve(): the method chosen, the contract on a few inputs, forced methods, errors."""

import warnings

import numpy as np
import pytest
from calibration_helpers import fake_calibration, use_calibration

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample
from nh_operators.models import predict
from nh_operators.solvers import solve_classical
from nh_operators.solving.answers import MAX_SUBSTEPS
from nh_operators.solving.network_pass import neural_solve

T = np.array([1.7, 0.05, 0.6, 2.0, 1.1])  # unsorted on purpose
SHO = nh.PHYSICAL_POTENTIALS["sho"]


def true_loss(sol, name="sho", t=T):
    q, p = nh.PHYSICAL_POTENTIALS[name].exact(t)
    return float(loss_per_sample(sol.q, sol.p, q, p)["L_tot"])


@pytest.mark.parametrize("tol", [1e-4, 1e-6, 1e-8])
def test_auto_meets_the_tolerance_at_exactly_the_times_asked(tol):
    sol = nh.solve("sho", T, tol=tol)
    assert sol.q.shape == (5,) and sol.tol == tol and sol.seconds > 0
    assert sol.error_estimate <= tol and true_loss(sol) <= tol
    # the shipped networks are ~1e-2: no network is expected to meet these tolerances
    assert sol.kind == "classical" and "no network expected to be cheaper" in sol.reason


def test_auto_without_tol_is_the_classical_solve_at_the_default():
    sol = nh.solve("mff", T)
    # solve lets the classical solver go to MAX_SUBSTEPS, where MFF's kink meets the default
    ref = solve_classical("mff", T, tol=nh.DEFAULT_TOL, max_substeps=MAX_SUBSTEPS)
    np.testing.assert_array_equal(sol.q, ref.q)
    assert sol.method == "rk4" and sol.tried[0]["substeps"] == ref.substeps
    assert sol.converged and true_loss(sol, "mff") <= nh.DEFAULT_TOL


def test_forced_integrator_and_callable_input():
    sol = nh.solve(SHO.V, T, tol=1e-9, method="yoshida4", dV=SHO.dV)
    assert sol.method == "yoshida4" and sol.reason == "forced" and true_loss(sol) <= 1e-9


def test_forced_network_interpolates_its_grid_prediction():
    sol = nh.solve("sho", nh.TIMES[::7], method="deeponet-alg1")
    net = nh.pretrained("deeponet-alg1").net
    q, p = predict(net, SHO.V(nh.SENSORS), nh.TIMES)
    np.testing.assert_allclose(sol.q, q[::7], atol=1e-12)
    np.testing.assert_allclose(sol.p, p[::7], atol=1e-12)
    assert sol.kind == "neural" and np.isfinite(sol.error_estimate)
    # DeepONet is ~1e-2 on the SHO; its calibrated estimate is above the true error
    assert true_loss(sol, t=nh.TIMES[::7]) <= sol.error_estimate


def test_forced_network_warns_when_its_estimate_exceeds_tol_or_the_input_is_outside():
    with pytest.warns(UserWarning, match="exceeds tol"):
        nh.solve("sho", T, tol=1e-9, method="deeponet-alg1")
    deep = 2 - 20 * nh.SENSORS * (1 - nh.SENSORS)  # min V = -3, below the generator's -2
    with pytest.warns(nh.OutOfDomainWarning, match="below -2"):
        nh.solve(deep, T, method="deeponet-alg1")
    with pytest.raises(ValueError, match=r"t ∈ \[0, 2\]"):
        nh.solve("sho", [0.5, 2.5], method="deeponet-alg1")


def test_auto_uses_a_network_expected_to_be_cheaper_and_falls_back_when_its_estimate_fails(
        monkeypatch):
    # 10 µs: cheaper than every shipped network's calibrated cost, so it is tried first
    use_calibration(monkeypatch, "deeponet-alg1",
                    fake_calibration(1.0, 1e-5, [1e-9, 1e-8, 1e-7]))
    _, _, estimate = neural_solve("deeponet-alg1", SHO, "exact V", T)
    loose = nh.solve("sho", T, tol=10 * estimate)
    assert loose.kind == "neural" and loose.method == "deeponet-alg1"
    assert loose.error_estimate == pytest.approx(estimate)
    assert "expected cheapest" in loose.reason
    tight = nh.solve("sho", T, tol=estimate / 10)
    assert tight.kind == "classical" and [a["accepted"] for a in tight.tried] == [False, True]
    assert "estimate" in tight.reason and true_loss(tight) <= estimate / 10
    # outside the domain (or beyond t = 2) auto does not try the network
    far = nh.solve("sho", [0.5, 3.0], tol=10 * estimate)
    assert far.kind == "classical" and "outside [0, 2]" in far.reason


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="unknown method 'rk5'"):
        nh.solve("sho", T, method="rk5")
    with pytest.raises(ValueError, match="tol must be a positive number"):
        nh.solve("sho", T, tol=-1.0)
    with pytest.raises(ValueError, match="non-empty array of finite times"):
        nh.solve("sho", [], tol=1e-6)
    with pytest.raises(ValueError, match="V\\(0\\)"):
        nh.solve("3 + q", T)


def test_solve_restores_thread_counts():
    import numba
    import torch

    before = torch.get_num_threads(), numba.get_num_threads()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nh.solve("sho", T, method="deeponet-alg1")
    nh.solve("sho", T, tol=1e-6)
    assert (torch.get_num_threads(), numba.get_num_threads()) == before


def test_the_classical_cost_weighed_is_the_one_of_the_input_kind(monkeypatch, pots):
    # B-spline potentials and sensor values: cheap; formulas: expensive
    cal = fake_calibration(1.0, 1e-3, [1e-9, 1e-8, 1e-7],
                           kinds={"bspline": [1e-6, 1e-6], "sensors": [1e-6, 1e-6]})
    use_calibration(monkeypatch, "deeponet-alg1", cal)
    _, _, estimate = neural_solve("deeponet-alg1", SHO, "exact V", T)
    assert nh.solve("sho", T, tol=10 * estimate).kind == "neural"
    # (other shipped networks keep their real calibrations and may still be tried)
    bspline = nh.solve(pots[0], T, tol=1.0)
    assert "deeponet-alg1" not in [a["method"] for a in bspline.tried]
    sensors = nh.solve(pots.V(nh.SENSORS)[0], T, tol=1.0)
    assert "deeponet-alg1" not in [a["method"] for a in sensors.tried]
