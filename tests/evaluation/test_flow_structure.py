"""Symplecticity and reversibility of flows: exact values on the harmonic oscillator,
RK4's known area loss, and autograd against finite differences on a network."""

import numpy as np
import pytest
import torch
from model_helpers import tiny

import nh_operators as nh
from nh_operators.evaluation import (area_defect, flow_jacobian, network_flow,
                                     network_jacobian, reversibility_error,
                                     symplectic_defect)
from nh_operators.models import cast_network

SHO = nh.PHYSICAL_POTENTIALS["sho"]  # ω = 4
DW = nh.PHYSICAL_POTENTIALS["double_well"]


def _classical(pot, t, method, steps):
    """The method's flow to the times t (uniform step t[-1] / steps)."""
    def flow(q0, p0):
        return nh.integrate([pot] * len(q0), np.atleast_1d(t), method, 1,
                            interval=float(np.max(t)) / steps, q0=q0, p0=p0,
                            check_resolution=False)
    return flow


def test_rk4_loses_exactly_its_stability_functions_area_on_the_sho():
    # one RK4 step multiplies areas by |R(iωh)|² = 1 − x⁶/72 + x⁸/576, x = ωh
    q0, p0 = np.array([0.4, 0.55]), np.array([0.5, -0.3])
    for steps in (20, 40):
        x = 4.0 * 1.0 / steps
        expected = abs((1 - x**6 / 72 + x**8 / 576) ** steps - 1)
        # the SHO flow is linear, so central differences are exact at any eps: a large
        # one keeps their rounding (1e-16 / eps) far below the 5e-7 measured (±2 eps
        # keeps every state bounded)
        J = flow_jacobian(_classical(SHO, [1.0], "rk4", steps), q0, p0, eps=1e-2)
        np.testing.assert_allclose(area_defect(J)[:, 0], expected, rtol=1e-4)
        # the same number up to rounding: both subtract O(|J|²) terms to leave ~2.5e-5,
        # so the relative rounding is about 1e-16 · |J|² / 2.5e-5 ≲ 1e-10
        np.testing.assert_allclose(symplectic_defect(J), np.sqrt(2) * area_defect(J),
                                   rtol=1e-8)


@pytest.mark.parametrize("method", ["verlet", "yoshida4"])
def test_splitting_methods_keep_area_on_a_nonlinear_potential(method):
    q0, p0 = np.array([0.3, 0.62]), np.array([0.4, -0.2])
    # the five-point differences' own error here is below 1e-10 at eps 1e-4 (it falls
    # ~100× per 3× smaller eps above that); RK4 at the same step loses 1.6e-5 and 2.2e-5
    J = flow_jacobian(_classical(DW, [1.0], method, 50), q0, p0, eps=1e-4)
    rk4 = flow_jacobian(_classical(DW, [1.0], "rk4", 50), q0, p0, eps=1e-4)
    assert np.all(area_defect(J) < 1e-9)
    assert np.all(area_defect(rk4) > 1e-5)


def test_reversibility():
    q0, p0 = np.array([0.3, 0.62]), np.array([0.4, -0.2])
    verlet = reversibility_error(_classical(DW, [1.0], "verlet", 50), q0, p0)
    rk4 = reversibility_error(_classical(DW, [1.0], "rk4", 10), q0, p0)
    assert np.all(verlet < 1e-12)  # symmetric: reversible to rounding
    assert np.all(rk4 > 1e-9)


def test_autograd_jacobian_of_a_network_matches_finite_differences():
    net = cast_network(tiny("traonet", seed=2, initial_state=True), torch.float64).eval()
    V = np.tile(SHO.V(nh.SENSORS), (3, 1))
    q0, p0, t = np.array([0.3, 0.5, 0.7]), np.array([0.2, -0.4, 0.1]), np.array([0.5, 1.5])
    exact = network_jacobian(net, V, q0, p0, t)
    approx = flow_jacobian(network_flow(net, V, t), q0, p0, eps=1e-6)
    assert exact.shape == (3, 2, 2, 2)
    np.testing.assert_allclose(exact, approx, rtol=0, atol=1e-7)
    assert np.all(area_defect(exact) > 0)  # an untrained network keeps nothing


def test_a_network_without_a_state_is_refused():
    with pytest.raises(ValueError, match="build it with initial_state=True"):
        network_jacobian(tiny("deeponet"), np.zeros((1, 100)), [0.5], [0.0], [1.0])


def test_project_energy_restores_the_momentum_of_a_right_position_and_keeps_its_sign():
    from nh_operators.evaluation import project_energy

    W = 4.0
    V = lambda q: 2 - W**2 * q * (1 - q) / 2                     # noqa: E731
    t = np.linspace(0, 2, 50)
    q0, p0 = 0.3, 0.5
    c = q0 - 0.5
    q = 0.5 + c * np.cos(W * t) + p0 / W * np.sin(W * t)
    p = -c * W * np.sin(W * t) + p0 * np.cos(W * t)
    E = np.array([0.5 * p0**2 + V(q0)])
    noisy = p * (1 + 0.1 * np.sin(7 * t))                        # wrong size, right sign
    qp, pp = project_energy(q[None], noisy[None], V, E)
    np.testing.assert_array_equal(qp[0], q)
    np.testing.assert_allclose(pp[0], p, atol=1e-12)
    # a position outside the orbit has no momentum there; outside [0, 1] it is clipped
    qp, pp = project_energy(np.array([[0.5, -0.2]]), np.array([[1.0, -3.0]]), V,
                            np.array([V(0.5) - 0.1]))
    assert qp[0].tolist() == [0.5, 0.0] and pp[0].tolist() == [0.0, -0.0]
