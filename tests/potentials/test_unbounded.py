"""extend_monotone: the paper's free fall exactly, other monotone potentials, and errors."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.potentials import extend_monotone


def free_fall():
    return extend_monotone(lambda q: -4 * (q - 0.5), 0.5, lambda q: -4 + 0 * q)


def test_free_fall_matches_the_paper():
    ff = free_fall()
    assert ff.T == pytest.approx(0.5, abs=1e-12) and ff.k == 3
    q = np.linspace(0.5, 1, 51)
    np.testing.assert_allclose(ff.V(q), 32 * q**3 - 48 * q**2 + 20 * q - 2, atol=1e-12)
    nh.check_bounded(ff.V, name="free fall")


def test_free_fall_trajectory_with_the_classical_solver_and_a_network():
    ff = free_fall()
    t = np.linspace(0, ff.T, 26)
    sol = nh.solve(ff, t, tol=1e-12)
    np.testing.assert_allclose(sol.q, 2 * t**2, atol=1e-9)
    np.testing.assert_allclose(sol.p, 4 * t, atol=1e-8)
    net = nh.solve(ff, t, method="deeponet")
    # the shipped DeepONet (test mean L_tot 3.6e-2) follows it within a few percent
    assert np.max(np.abs(net.q - 2 * t**2)) < 0.05 and np.max(np.abs(net.p - 4 * t)) < 0.15


@pytest.mark.parametrize("V, dV, Q", [
    (lambda q: 2 - 2 * q - 4 * q**2, lambda q: -2 - 8 * q, 0.4),
    (lambda q: 2 * np.exp(-3 * q), lambda q: -6 * np.exp(-3 * q), 0.6),
    (lambda q: 2 - np.sinh(4 * q), lambda q: -4 * np.cosh(4 * q), 0.3),
])
def test_other_monotone_potentials_reach_Q_at_T_and_are_C2(V, dV, Q):
    ext = extend_monotone(V, Q, dV)
    nh.check_bounded(ext.V)
    # an independent check of T: the solved trajectory is at Q at time T, with the
    # speed energy conservation gives
    sol = nh.solve(ext, [ext.T], tol=1e-12)
    assert sol.q[0] == pytest.approx(Q, abs=1e-7)
    assert sol.p[0] == pytest.approx(np.sqrt(2 * (2 - V(Q))), rel=1e-6)
    h = 1e-4  # value, slope and curvature continue across Q
    left, right = ext.V(np.array([Q - h, Q])), ext.V(np.array([Q, Q + h]))
    assert ext.V(Q + 1e-12) == pytest.approx(V(Q), abs=1e-9)
    assert (right[1] - right[0]) / h == pytest.approx((left[1] - left[0]) / h, abs=1e-2)
    d2_left = (ext.dV(Q) - ext.dV(Q - h)) / h
    d2_right = (ext.dV(Q + h) - ext.dV(Q + 1e-12)) / h
    assert d2_right == pytest.approx(d2_left, rel=1e-2, abs=1e-2)


def test_without_dV_the_difference_quotient_is_used():
    a = extend_monotone(lambda q: 2 * np.exp(-3 * q), 0.6)
    b = extend_monotone(lambda q: 2 * np.exp(-3 * q), 0.6, lambda q: -6 * np.exp(-3 * q))
    assert a.T == pytest.approx(b.T, rel=1e-12) and a.V(0.8) == pytest.approx(b.V(0.8), rel=1e-6)


@pytest.mark.parametrize("V, Q, message", [
    (lambda q: 2 - 8 * q + 12 * q**2, 0.5, r"not decreasing on \[0, 0.5\]: it rises after q = 0.33"),
    (lambda q: 1.5 - q, 0.5, r"V\(0\) = 1.5.*need V\(0\) = V0"),
    (lambda q: 2 - q**2, 0.5, "never leaves q = 0"),
    (lambda q: 2 - 10 * q + 24 * q**2, 0.2, "no extension"),
    (lambda q: 2 - q, 1.0, r"Q must lie in \(0, 1\)"),
])
def test_clear_errors(V, Q, message):
    with pytest.raises(ValueError, match=message):
        extend_monotone(V, Q)
