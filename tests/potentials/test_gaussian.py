"""The generator's BLAS-free Gaussian draw: exp, Cholesky and product in plain loops."""

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest

from nh_operators.potentials import BoundedPotentialSpace
from nh_operators.potentials.gaussian import (DRAW_VERSION, JITTER, cholesky_lower,
                                              grf_values, lower_times, portable_exp,
                                              se_covariance)


def test_portable_exp_is_within_one_ulp_of_the_exact_value():
    getcontext().prec = 40
    xs = np.concatenate([-np.geomspace(1e-12, 740.0, 400), np.linspace(-1.0, 700.0, 200)])
    for x in xs:
        got = portable_exp(float(x))
        exact = Decimal(float(x)).exp()
        assert abs(Decimal(got) - exact) <= Decimal(math.ulp(got)), x
    assert portable_exp(0.0) == 1.0
    assert portable_exp(1.0) == math.nextafter(math.e, math.inf)  # e rounds down; 1 ulp
    assert portable_exp(-800.0) == 0.0 and portable_exp(710.0) == math.inf
    assert math.isnan(portable_exp(math.nan))
    assert portable_exp(-745.0) == math.exp(-745.0) == 5e-324  # the subnormal end


def test_cholesky_lower_of_a_2x2_by_hand():
    # [[4, 2], [2, 5]] = L Lᵀ with L = [[2, 0], [1, 2]], every step exact
    assert cholesky_lower([[4.0, 2.0], [2.0, 5.0]]).tolist() == [[2.0, 0.0], [1.0, 2.0]]
    # [[9, 3], [3, 2]]: l11 = 3, l21 = 1, l22 = sqrt(2 - 1) = 1
    assert cholesky_lower(np.array([[9.0, 3.0], [3.0, 2.0]])).tolist() == [[3.0, 0.0],
                                                                           [1.0, 1.0]]
    assert lower_times([[2.0, 0.0], [1.0, 2.0]], [1.0, -1.0]).tolist() == [2.0, -1.0]


def test_cholesky_lower_matches_numpy():
    rng = np.random.default_rng(5)
    for n in range(1, 9):
        a = rng.standard_normal((n, n))
        spd = a @ a.T + n * np.eye(n)  # well conditioned: entries of L agree to rounding
        low = cholesky_lower(spd)
        assert np.max(np.abs(low - np.linalg.cholesky(spd))) < 1e-14 * np.max(np.abs(low))
        assert np.array_equal(np.triu(low, 1), np.zeros((n, n)))
        z = rng.standard_normal(n)
        assert np.max(np.abs(lower_times(low, z) - low @ z)) < 1e-14 * np.max(np.abs(low @ z))


def test_cholesky_lower_refuses_what_is_not_positive_definite():
    with pytest.raises(ValueError, match="not positive definite .pivot 1 is -3.0"):
        cholesky_lower([[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(ValueError, match="square matrix, got shape .2, 3"):
        cholesky_lower(np.zeros((2, 3)))
    with pytest.raises(ValueError, match="L of shape .2, 2. and z of 3 entries"):
        lower_times(np.eye(2), [1.0, 2.0, 3.0])


def test_generator_covariance_and_draw_agree_with_numpy_to_rounding():
    rng = np.random.default_rng(11)
    worst_k = worst_x = 0.0
    for _ in range(300):
        n, ell = int(rng.integers(2, 8)), float(rng.uniform(0.01, 0.2))
        y = np.arange(1, n + 1) / (n + 1)
        cov = np.exp(-((y[:, None] - y[None, :]) ** 2) / (2 * ell**2)) + JITTER * np.eye(n)
        worst_k = max(worst_k, float(np.max(np.abs(np.array(se_covariance(n, ell)) - cov))))
        z = rng.standard_normal(n)
        old = np.linalg.cholesky(cov) @ z  # draw 1
        worst_x = max(worst_x, float(np.max(np.abs(grf_values(n, ell, z) - old))
                                     / np.max(np.abs(old))))
    assert worst_k <= 2.0**-53  # each entry within an ulp of 1 of np.exp's
    assert 0.0 < worst_x < 1e-13  # draw 2 = draw 1 but for the last bits


def test_the_space_draws_the_same_random_numbers_as_draw_1():
    """Draw 2 takes the same random numbers in the same order: after any number of
    draws the generator's state is that of draw 1's stream."""
    a = BoundedPotentialSpace(seed=3)
    feats, a_scales = a.random_with_scales(40)
    rng = np.random.default_rng(3)
    for k in range(40):  # draw 1's sequence of calls, replayed
        n = int(rng.integers(2, 8))
        assert a_scales[k] == rng.uniform(0.01, 0.2)
        rng.standard_normal(n)
        i = np.arange(1, n + 1)
        low, high = (i - 1) / n + 0.025, i / n - 0.025
        low[0], high[-1] = 0.05, 0.95
        qs = rng.uniform(low, high)
        assert feats[k, 0] == n and np.array_equal(feats[k, 1:1 + n], qs)
    assert a.rng.bit_generator.state == rng.bit_generator.state
    assert a.params()["draw"] == DRAW_VERSION == 2
