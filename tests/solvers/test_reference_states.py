"""The truth from any bounded starting state (q0, p0): exact solutions, an independent
solve, and the checks on the state."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from nh_operators import TIMES, V0, BoundedPotentialSpace, integrate, reference_solve
from nh_operators.potentials import PHYSICAL_POTENTIALS
from nh_operators.solvers import random_states
from nh_operators.solvers.rows import row_source

SHO = PHYSICAL_POTENTIALS["sho"]  # V = 8 (q − 1/2)², ω = 4


@pytest.fixture(scope="module")
def pots_and_states():
    pots = BoundedPotentialSpace.potentials(BoundedPotentialSpace(seed=31).random(12))
    q0, p0 = random_states(row_source(pots, "exact V").values_at, 12,
                           np.random.default_rng(31))
    return pots, q0, p0


def test_sho_from_a_state_is_the_exact_solution():
    # from (1/2 + a, b): q − 1/2 = a cos 4t + (b/4) sin 4t, p = q'
    a, b = -0.2, 1.5
    q, p = reference_solve(SHO, TIMES, q0=0.5 + a, p0=b)
    assert np.max(np.abs(q - (0.5 + a * np.cos(4 * TIMES) + b / 4 * np.sin(4 * TIMES)))) < 1e-10
    assert np.max(np.abs(p - (-4 * a * np.sin(4 * TIMES) + b * np.cos(4 * TIMES)))) < 1e-10


def test_bspline_curves_from_states_match_an_independent_solve(pots_and_states):
    pots, q0, p0 = pots_and_states
    q, p, info = reference_solve(pots, TIMES, q0=q0, p0=p0, full_output=True)
    # it starts where asked
    np.testing.assert_allclose(q[:, 0], q0, rtol=0, atol=1e-13)
    np.testing.assert_array_equal(p[:, 0], p0)
    # energy kept to the starting energy, not V0
    energy = 0.5 * p0**2 + np.array([pots[i].V(q0[i]) for i in range(len(pots))])
    assert np.all(energy < V0)
    assert np.all(info["energy_error"] <= 1e-10)
    assert np.max(np.abs(0.5 * p**2 + np.stack([pots[i].V(q[i]) for i in range(len(pots))])
                         - energy[:, None])) <= 1e-10
    # independent: scipy's DOP853 in q on the inverted curve (not the curve parameter)
    for i in (0, 7):
        sol = solve_ivp(lambda _, y, i=i: (y[1], -float(pots[i].dV(y[0]))), (0.0, 2.0),
                        (q0[i], p0[i]), method="DOP853", t_eval=TIMES, rtol=1e-13, atol=1e-13)
        assert np.max(np.abs(sol.y[0] - q[i])) < 1e-9
        assert np.max(np.abs(sol.y[1] - p[i])) < 1e-8
    # and RK4 at a tiny step on the same curve, every row
    qr, pr = integrate(pots, TIMES, substeps=2048, q0=q0, p0=p0, check_resolution=False)
    assert np.max(np.abs(qr - q)) < 1e-9 and np.max(np.abs(pr - p)) < 1e-8


def test_rest_at_zero_is_unchanged_and_a_batch_is_its_rows(pots_and_states):
    pots, q0, p0 = pots_and_states
    q, p = reference_solve(pots, TIMES)
    q2, p2 = reference_solve(pots, TIMES, q0=np.zeros(len(pots)), p0=0.0)
    np.testing.assert_array_equal(q, q2)
    np.testing.assert_array_equal(p, p2)
    qs, ps = reference_solve(pots, TIMES, q0=q0, p0=p0)
    q1, p1 = reference_solve(pots[3], TIMES, q0=q0[3], p0=p0[3])
    np.testing.assert_array_equal(q1, qs[3])
    np.testing.assert_array_equal(p1, ps[3])


def test_a_state_that_leaves_the_box_is_refused(pots_and_states):
    pots = pots_and_states[0]
    with pytest.raises(ValueError, match=r"row 2: the state .* has energy .* > V0 = 2"):
        reference_solve(pots, TIMES, q0=0.5, p0=np.where(np.arange(12) == 2, 2.5, 0.0))
    with pytest.raises(ValueError, match=r"q0 = 1.5 is outside \[0, 1\]"):
        reference_solve(pots[0], TIMES, q0=1.5)
    with pytest.raises(ValueError, match=r"p0 must be a scalar or have one value per row"):
        reference_solve(pots, TIMES, p0=np.zeros(3))
    with pytest.raises(ValueError, match="has energy"):
        reference_solve(SHO, TIMES, q0=0.5, p0=3.0)
