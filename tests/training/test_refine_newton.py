"""nh.refine(..., method="newton"): a network's trajectory as Newton's first guess."""

import warnings

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.potentials import ood_potentials
from nh_operators.solvers import reference_solve


@pytest.fixture(scope="module")
def model():
    return nh.pretrained("deeponet-paper")


def l_tot(q, p, ref):
    return 0.5 * (np.mean((q - ref[0]) ** 2) + np.mean((p - ref[1]) ** 2))


@pytest.mark.parametrize("name", ["sho", "double_well", "morse", "smff"])
def test_newton_refinement_reaches_the_exact_trajectory(model, name):
    pot = nh.PHYSICAL_POTENTIALS[name]
    ref = tuple(np.asarray(a).reshape(-1) for a in reference_solve(pot, nh.TIMES))
    q, p = nh.predict(model, pot.V(nh.SENSORS), nh.TIMES)
    r = nh.refine(model, pot, nh.TIMES, method="newton", tol=1e-10)
    assert r.converged and r.estimate <= 1e-10 and r.net is None
    assert l_tot(q, p, ref) > 1e-4  # the network alone
    assert l_tot(r.q, r.p, ref) < 1e-20
    assert r.residual_after < 1e-12 * r.residual_before


def test_sensor_values_refine_to_their_spline(model):
    """Given 100 sensor values, the answer is the trajectory of their spline."""
    V = nh.PHYSICAL_POTENTIALS["morse"].V(nh.SENSORS)
    r = nh.refine(model, V, nh.TIMES, method="newton", tol=1e-5)
    spline = nh.solve_classical(V, nh.TIMES, tol=1e-12)
    assert r.converged and r.estimate <= 1e-5
    np.testing.assert_allclose(r.q, spline.q, atol=1e-5)
    np.testing.assert_allclose(r.p, spline.p, atol=1e-5)
    # the spline's third derivative jumps at the sensors: its trajectory is not smooth
    # enough for a global polynomial to reach 1e-10 with 512 intervals, and it says so
    assert not nh.refine(model, V, nh.TIMES, method="newton", tol=1e-10).converged


def test_a_diverging_newton_keeps_the_network_answer(model):
    ripple = ood_potentials(2, 0)[1]
    q, p = nh.predict(model, ripple.V(nh.SENSORS), nh.TIMES)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # overflow while it diverges
        r = nh.refine(model, ripple, nh.TIMES, method="newton")
    assert not r.converged
    np.testing.assert_allclose(r.q, q, atol=1e-6)
    assert r.residual_after == r.residual_before


def test_newton_refinement_errors_are_named(model):
    with pytest.raises(ValueError, match=r"method must be 'weights' or 'newton'"):
        nh.refine(model, nh.PHYSICAL_POTENTIALS["sho"], method="bfgs")
    with pytest.raises(ValueError, match=r"not the weights: \['lr', 'steps'\] do not apply"):
        nh.refine(model, nh.PHYSICAL_POTENTIALS["sho"], method="newton", steps=5, lr=0.1)
    with pytest.raises(ValueError, match=r"times in \[0, 2\]"):
        nh.refine(model, nh.PHYSICAL_POTENTIALS["sho"], np.array([0.5, 3.0]),
                  method="newton")
