"""The domain check's compiled paths give the answers of the plain NumPy reductions.

``domain_stats`` takes its differences' maxima from a compiled pass and its minima and
maxima from ``reduceat``; ``domain_violations`` first asks ``surely_inside`` and builds
statistics and messages only when a row may be outside. Both must leave every number,
every message and every raised error as the row-by-row NumPy code gives them.
"""

import warnings

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.evaluation import extreme_potentials
from nh_operators.potentials import (
    GENERATOR_DOMAIN,
    domain,
    domain_stats,
    domain_violations,
    in_domain,
    wall_forces,
)

WIDTH = nh.SENSORS[1] - nh.SENSORS[0]


def reference_stats(rows):
    """domain_stats as plain row-wise NumPy reductions (the definition)."""
    first = np.diff(rows, axis=1)
    return {"min": rows.min(axis=1), "max": rows.max(axis=1),
            "slope": np.abs(first).max(axis=1) / WIDTH,
            "curvature": np.abs(np.diff(first, axis=1)).max(axis=1) / WIDTH**2,
            "wall_force": wall_forces(rows).min(axis=1)}


def assert_same_bits(got, want):
    assert got.keys() == want.keys()
    for key in want:
        assert got[key].dtype == want[key].dtype, key
        assert got[key].tobytes() == want[key].tobytes(), key  # signs of zeros included


def batches():
    rng = np.random.default_rng(11)
    space = nh.BoundedPotentialSpace(seed=3)
    yield space.potentials(space.random(257)).V(nh.SENSORS)              # odd count
    yield rng.choice([0.0, -0.0, 1.0], size=(301, 100))                 # zero minima
    yield rng.choice([0.0, -0.0, -1.0], size=(300, 100))                # zero maxima
    yield rng.choice([0.0, -0.0, 5e-324, -5e-324], size=(64, 100))      # subnormals
    yield np.asfortranarray(rng.normal(size=(33, 100)) * 1e3)          # Fortran order
    yield rng.normal(size=(40, 100))[::3]                                # strided rows
    yield rng.normal(size=(9, 100)).astype(np.float32)                   # float32 stays
    yield rng.normal(size=(1, 100))                                      # one row


def test_domain_stats_equal_the_row_wise_reductions_bit_for_bit():
    for rows in batches():
        assert_same_bits(domain_stats(rows), reference_stats(rows))


def test_domain_stats_of_no_rows_are_empty():
    stats = domain_stats(np.empty((0, 100)))
    assert [v.shape for v in stats.values()] == [(0,)] * 5


def near_bounds():
    """(row, domain) pairs: generator rows, each against a domain with one bound within
    a few ulps of that row's statistic (above and below), the other bounds loose."""
    space = nh.BoundedPotentialSpace(seed=9)
    rows = space.potentials(space.random(8)).V(nh.SENSORS)
    stats = reference_stats(rows)
    loose = {"V_range": (-1e3, 1e3), "max_slope": 1e9, "min_V_at_most": 1e9,
             "max_curvature": 1e12, "min_wall_force": 0.0, "source": "a loose domain"}
    eps = np.finfo(np.float64).eps
    pairs = []
    for i, row in enumerate(rows):
        lo, hi = stats["min"][i] + 1e-9, stats["max"][i] - 1e-9
        for k in range(-6, 7):
            tight = [("max_slope", stats["slope"][i] * (1 + k * eps)),
                     ("max_curvature", stats["curvature"][i] * (1 + k * eps)),
                     ("min_wall_force", stats["wall_force"][i] * (1 + k * eps)),
                     ("min_V_at_most", stats["min"][i] + k * eps * abs(stats["min"][i])),
                     ("V_range", (lo + k * eps * abs(lo), 1e3)),
                     ("V_range", (-1e3, hi + k * eps * abs(hi)))]
            pairs += [(row, {**loose, key: value}) for key, value in tight]
    return pairs


def test_surely_inside_never_passes_a_row_the_exact_check_rejects(monkeypatch):
    pairs = near_bounds()
    exact = np.array([bool(in_domain(row, d)) for row, d in pairs])
    assert 0.3 < exact.mean() < 0.7                  # both sides of every bound are hit
    sure = np.array([domain.surely_inside(row[None], *domain._bounds(d)) for row, d in pairs])
    assert not (sure & ~exact).any()
    assert sure.sum() >= 0.75 * exact.sum()          # it defers only near the wall bound
    fast = [domain_violations(row, d) for row, d in pairs]
    monkeypatch.setattr(domain, "surely_inside", lambda *args: False)  # exact path only
    assert fast == [domain_violations(row, d) for row, d in pairs]
    assert [m == [] for m in fast] == exact.tolist()


def test_a_batch_is_inside_only_when_every_row_is():
    space = nh.BoundedPotentialSpace(seed=5)
    V = space.potentials(space.random(21)).V(nh.SENSORS)
    bounds = domain._bounds(GENERATOR_DOMAIN)
    assert domain.surely_inside(V, *bounds)
    deep = extreme_potentials()["deep_well"].V(nh.SENSORS)
    for row in (0, 7, 20):                           # an even, an odd and the unpaired row
        W = V.copy()
        W[row] = deep
        assert not domain.surely_inside(W, *bounds)
        (message,) = [m for m in domain_violations(W) if "below -2" in m]
        assert message.startswith(f"V[{row}] (1 of 21 rows) has values below -2")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values_still_raise(bad):
    space = nh.BoundedPotentialSpace(seed=6)
    V = space.potentials(space.random(4)).V(nh.SENSORS)
    V[2, 40] = bad
    assert not domain.surely_inside(V, *domain._bounds(GENERATOR_DOMAIN))
    with pytest.raises(ValueError, match="V must hold finite values at the 100 sensors, "
                                         r"shape \(100,\) or \(N, 100\); got shape \(4, 100\)"):
        domain_violations(V)
    big = np.full((1, 100), 1e308)  # finite, though its sum is not: the exact path decides
    with warnings.catch_warnings():  # the wall forces overflow (as they always did)
        warnings.simplefilter("ignore", RuntimeWarning)
        assert domain_violations(big)[0] == ("V[0] (1 of 1 rows) has values above 2 (the "
                                             "generator keeps V in [-2, 2]): max V = 1e+308 "
                                             "in row 0")
