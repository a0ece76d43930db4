"""Out-of-distribution potentials: bounded, exact derivatives, reproducible, and new."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.potentials import (
    OOD_FAMILIES,
    domain_violations,
    ood_potential,
    ood_potentials,
)

POTS = ood_potentials(40, seed=3)


@pytest.mark.parametrize("i", range(8))
def test_bounded_with_exact_derivative(i):
    for pot in POTS:
        nh.check_bounded(pot.V, name=pot.formula)
    pot = POTS[i]
    q = np.linspace(0.01, 0.99, 97)
    h = 1e-5
    fd = (pot.V(q + h) - pot.V(q - h)) / (2 * h)
    np.testing.assert_allclose(pot.dV(q), fd, rtol=1e-6, atol=1e-6)
    assert pot.V(0.0) == pytest.approx(2.0, abs=1e-12)
    assert pot.V(1.0) == pytest.approx(2.0, abs=1e-12)


def test_reproducible_and_every_family_present():
    again = ood_potentials(40, seed=3)
    q = np.linspace(0, 1, 11)
    for a, b in zip(POTS, again):
        np.testing.assert_array_equal(a.V(q), b.V(q))
    assert {p.name for p in POTS} == set(OOD_FAMILIES)
    assert not np.array_equal(ood_potentials(1, seed=4)[0].V(q), POTS[0].V(q))


def test_some_lie_outside_the_generator_domain():
    outside = sum(bool(domain_violations(p.V(nh.SENSORS))) for p in POTS)
    assert 0 < outside < len(POTS)


def test_unknown_family():
    with pytest.raises(ValueError, match="unknown family 'cubic'"):
        ood_potential("cubic", np.random.default_rng(0))
