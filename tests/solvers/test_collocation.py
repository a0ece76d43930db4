"""Chebyshev collocation with Newton's method: exact solutions, spectral convergence,
honest failure on a kink."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.solvers import (chebyshev_points, collocate, collocation_residual,
                                  newton_collocation, reference_solve)


def sho_force(q):
    return 16.0 * (q - 0.5)


def sho_stiffness(q):
    return 16.0 + 0.0 * q


def difference_stiffness(dV):
    return lambda q: (dV(q + 1e-6) - dV(q - 1e-6)) / 2e-6


@pytest.mark.parametrize("q0, p0", [(0.0, 0.0), (0.1, 0.3)])
def test_harmonic_oscillator_is_exact_from_any_guess(q0, p0):
    t = np.linspace(0, 2, 37)
    exact_q = 0.5 + (q0 - 0.5) * np.cos(4 * t) + p0 / 4 * np.sin(4 * t)
    exact_p = -4 * (q0 - 0.5) * np.sin(4 * t) + p0 * np.cos(4 * t)
    sol = newton_collocation(sho_force, sho_stiffness, np.zeros(41), 2.0, q0, p0)
    assert sol.converged and sol.steps <= 3  # linear: one step, one to see it stopped
    q, p = sol(t)
    np.testing.assert_allclose(q, exact_q, atol=1e-11)
    np.testing.assert_allclose(p, exact_p, atol=1e-10)
    assert sol.estimate < 1e-12
    assert collocation_residual(sol.q, sol.p, 2.0, sho_force) < 1e-20


def test_a_step_tolerance_below_rounding_stops_at_the_rounding_floor():
    """Newton's steps cannot shrink below rounding: asked for steps below 1e-20, it
    stops, converged, once a step under eps · N² no longer halves (before, it ran all
    its steps and said it had not converged), and the answer is as exact as before."""
    t = np.linspace(0, 2, 37)
    exact_q = 0.5 - 0.5 * np.cos(4 * t)
    well = nh.PHYSICAL_POTENTIALS["double_well"]
    near = np.asarray(reference_solve(well, chebyshev_points(512, 2.0))[0]).reshape(-1)
    for force, stiffness, guess in [(sho_force, sho_stiffness, np.full(257, 0.5)),
                                    (well.dV, difference_stiffness(well.dV), near)]:
        loose = newton_collocation(force, stiffness, guess, 2.0)
        tight = newton_collocation(force, stiffness, guess, 2.0, step_tol=1e-20)
        assert tight.converged and tight.steps < 30
        assert tight.steps >= loose.steps
        np.testing.assert_allclose(tight.q, loose.q, rtol=0, atol=1e-10)
        if force is sho_force:
            np.testing.assert_allclose(tight(t)[0], exact_q, atol=1e-10)


def test_points_and_interpolation_at_the_points():
    t = chebyshev_points(8, 2.0)
    assert t[0] == 0.0 and t[-1] == 2.0 and np.all(np.diff(t) > 0)
    np.testing.assert_allclose(t[4], 1.0, atol=1e-15)  # the middle point
    sol = newton_collocation(sho_force, sho_stiffness, np.zeros(9), 2.0)
    q, p = sol(t)
    assert np.array_equal(q, sol.q) and np.array_equal(p, sol.p)


@pytest.mark.parametrize("name", ["double_well", "morse", "smff"])
@pytest.mark.parametrize("tol", [1e-6, 1e-10])
def test_smooth_physical_potentials_converge_and_the_estimate_bounds_the_error(name, tol):
    pot = nh.PHYSICAL_POTENTIALS[name]
    q_ref, p_ref = (np.asarray(a).reshape(-1) for a in reference_solve(pot, nh.TIMES))
    guess = np.interp  # a poor guess: the truth plus a wiggle of 0.02
    sol = collocate(pot.dV, difference_stiffness(pot.dV),
                    lambda t: guess(t, nh.TIMES, q_ref) + 0.02 * np.sin(7 * t), 2.0, tol=tol)
    assert sol.converged and sol.estimate <= tol
    q, p = sol(nh.TIMES)
    error = max(np.abs(q - q_ref).max(), np.abs(p - p_ref).max())
    assert error <= 10 * tol


def test_a_kinked_force_is_reported_not_converged():
    pot = nh.PHYSICAL_POTENTIALS["mff"]
    q_ref = np.asarray(reference_solve(pot, nh.TIMES)[0]).reshape(-1)
    sol = collocate(pot.dV, difference_stiffness(pot.dV),
                    lambda t: np.interp(t, nh.TIMES, q_ref), 2.0, tol=1e-8, n_max=128)
    assert not sol.converged and sol.estimate > 1e-8
    assert sol.t.size == 129  # it tried up to n_max


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="at least 4 points"):
        newton_collocation(sho_force, sho_stiffness, np.zeros(3), 2.0)
    with pytest.raises(ValueError, match="T > 0"):
        newton_collocation(sho_force, sho_stiffness, np.zeros(9), 0.0)
    with pytest.raises(ValueError, match="tol must be positive"):
        collocate(sho_force, sho_stiffness, np.zeros_like, 2.0, tol=0.0)
