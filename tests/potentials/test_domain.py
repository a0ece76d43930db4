"""The generator's domain at the sensors: what domain_violations accepts and reports."""


import numpy as np
import pytest
from solver_helpers import generator_sensor_values

import nh_operators as nh
from nh_operators.evaluation import extreme_potentials
from nh_operators.potentials import (
    GENERATOR_DOMAIN,
    domain_violations,
    fit_domain,
    in_domain,
    wall_forces,
)

SENSOR_VALUES = {name: pot.V(nh.SENSORS) for name, pot in extreme_potentials().items()}


def test_generator_samples_are_inside_the_domain():
    assert domain_violations(generator_sensor_values()) == []
    space = nh.BoundedPotentialSpace(seed=7)
    assert domain_violations(space.potentials(space.random(300)).V(nh.SENSORS)) == []
    for name, pot in nh.PHYSICAL_POTENTIALS.items():
        assert domain_violations(pot.V(nh.SENSORS)) == [], name


def test_extreme_cases_are_reported():
    reasons = {name: domain_violations(V) for name, V in SENSOR_VALUES.items()}
    assert reasons["mff"] == reasons["smff_200"] == []
    assert len(reasons["steep_wall"]) == 2
    assert "steeper than the generator's max |V'| = 80: max |ΔV/Δq| = 125.9" in (
        reasons["steep_wall"][0])
    assert reasons["deep_well"][0].startswith("V has values below -2")
    assert "min V = -99.9" in reasons["deep_well"][0]
    assert reasons["near_flat"] == [
        f"V never dips below {GENERATOR_DOMAIN['min_V_at_most']:.3g} (every potential of "
        "the generator does: too flat): min V = 1.99",
        "V has a wall whose force does not point inward as firmly as in the generator "
        "(-V'(0) and V'(1) > 0.336; from rest there a particle stays or leaves [0, 1]): "
        "weakest wall force = 0.04"]
    batch = np.stack([SENSOR_VALUES["mff"], SENSOR_VALUES["deep_well"], SENSOR_VALUES["mff"]])
    (message,) = [m for m in domain_violations(batch) if "below -2" in m]
    assert message.startswith("V[1] (1 of 3 rows) has values below -2") and "in row 1" in message
    with pytest.raises(ValueError, match="finite values at the 100 sensors"):
        domain_violations(np.zeros(99))




def test_in_domain_agrees_with_the_messages_row_by_row():
    rows = np.stack(list(SENSOR_VALUES.values()) + [generator_sensor_values()[0]])
    want = np.array([domain_violations(V) == [] for V in rows])
    assert want.any() and not want.all()
    np.testing.assert_array_equal(in_domain(rows), want)
    assert in_domain(rows[0]) == want[0]


def test_a_fitted_domain_holds_its_rows_and_widens_each_bound_by_the_slack():
    q = nh.SENSORS
    rows = np.stack([2 - 8 * q * (1 - q), 2 - 4 * q * (1 - q)])  # min V 0 and 1 (at q = 1/2)
    d = fit_domain(rows, slack=0.5, source="two parabolas")
    h = q[1] - q[0]
    steepest = np.abs(np.diff(rows[0])).max() / h
    assert d["max_slope"] == pytest.approx(1.5 * steepest, rel=1e-12)
    assert d["max_curvature"] == pytest.approx(1.5 * 16, rel=1e-9)  # |V''| = 16 exactly
    lowest_min = rows[1].min()
    assert d["min_V_at_most"] == pytest.approx(lowest_min + 0.5 * (2 - lowest_min))
    assert d["V_range"][0] == pytest.approx(rows.min() - 0.05 * (2 - rows.min()))
    assert d["rows"] == 2 and in_domain(rows, d).all()
    flat = 2 - 1 * q * (1 - q)  # min V 1.75: flatter than any training row, beyond the slack
    steep = 2 - 12.5 * q * (1 - q)  # slope 12.4 > 1.5 × 7.9 and curvature 25 > 24
    assert not in_domain(np.stack([flat, steep]), d).any()
    too_flat, weak_walls = domain_violations(flat, d)
    assert "every potential of two parabolas does: too flat" in too_flat
    # the weakest wall of the rows pushes with |V'(0)| = 4 (the cubic through four
    # sensors differentiates a parabola exactly); the flat one's walls push with 1
    assert d["min_wall_force"] == pytest.approx(4 / 1.5, rel=1e-9)
    assert "weakest wall force = 1" in weak_walls
    assert fit_domain(rows, slack=0)["max_slope"] == pytest.approx(steepest)


def test_a_wall_that_does_not_push_inward_is_outside_every_domain():
    """V = 2 - 48 q² (1 - q)² has V'(0) = V'(1) = 0: from rest at q = 0 the particle
    stays (or, on a spline whose slope there is slightly outward, leaves [0, 1]): no
    training trajectory did either, and the error estimate, first order, misses it."""
    q = nh.SENSORS
    hilltop = 2 - 48 * q**2 * (1 - q) ** 2
    np.testing.assert_allclose(wall_forces(hilltop), [0.0, 0.0], atol=2e-3)
    np.testing.assert_allclose(wall_forces(2 - 3 * q * (1 - q) * (1 + q)), [3.0, 6.0])
    assert not in_domain(hilltop) and in_domain(8 * (q - 0.5) ** 2)
    (message,) = domain_violations(hilltop)
    assert message.startswith("V has a wall whose force does not point inward")


def test_fit_domain_rejects_bad_rows_and_slack():
    with pytest.raises(ValueError, match="shape \\(N, 100\\) with N ≥ 1"):
        fit_domain(np.zeros((0, 100)))
    with pytest.raises(ValueError, match="finite values"):
        fit_domain(np.full((2, 100), np.nan))
    with pytest.raises(ValueError, match="slack must be ≥ 0"):
        fit_domain(np.zeros((2, 100)), slack=-1)
