"""Statistics and the energy error of a trajectory."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.evaluation import energy_error, loss_per_sample, summarize


def test_summarize_matches_hand_values():
    s = summarize([4.0, 1.0, 3.0, 2.0, 10.0])
    assert s == {"mean": 4.0, "std": pytest.approx(np.sqrt(10.0)), "median": 3.0,
                 "iqr": 2.0, "n": 5}  # percentiles 25/75 at 2 and 4


def test_summarize_refuses_empty_or_non_finite():
    with pytest.raises(ValueError, match="at least one"):
        summarize([])
    with pytest.raises(ValueError, match="1 of 3 values are not finite"):
        summarize([1.0, np.nan, 2.0])


def test_loss_per_sample_is_the_papers_metric():
    q, p = np.zeros((2, 4)), np.zeros((2, 4))
    q_ref = np.array([[1.0, 1, 1, 1], [0, 0, 0, 2]])
    p_ref = np.array([[0.0, 0, 0, 0], [2, 0, 0, 0]])
    losses = loss_per_sample(q, p, q_ref, p_ref)
    np.testing.assert_allclose(losses["L_q"], [1.0, 1.0])
    np.testing.assert_allclose(losses["L_p"], [0.0, 1.0])
    np.testing.assert_allclose(losses["L_tot"], [0.5, 1.0])


def test_energy_error_of_the_exact_sho_and_of_a_known_perturbation():
    sho = nh.PHYSICAL_POTENTIALS["sho"]
    q, p = sho.exact(nh.TIMES)
    assert energy_error(q, p, sho) < 1e-14
    p2 = p.copy()
    p2[37] += 1e-3  # energy changes by p δ + δ²/2 at that time only
    assert energy_error(q, p2, sho) == pytest.approx(abs(p[37] * 1e-3 + 0.5e-6), rel=1e-8)


def test_energy_error_of_labels_on_a_batch(pots, reference):
    q, p, _ = reference
    err = energy_error(q, p, pots)
    assert err.shape == (len(pots),)
    assert np.all(err < 1e-10)
    with pytest.raises(ValueError, match="needs q of shape"):
        energy_error(q[:3], p[:3], pots)
