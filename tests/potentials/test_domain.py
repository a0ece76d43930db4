"""The generator's domain at the sensors: what domain_violations accepts and reports."""


import numpy as np
import pytest
from solver_helpers import generator_sensor_values

import nh_operators as nh
from nh_operators.evaluation import extreme_potentials
from nh_operators.potentials import GENERATOR_DOMAIN, domain_violations

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
    assert reasons["near_flat"] == [f"V never dips below {GENERATOR_DOMAIN['min_V_at_most']:.3g} "
                                    "(every generator potential does: too flat): min V = 1.99"]
    batch = np.stack([SENSOR_VALUES["mff"], SENSOR_VALUES["deep_well"], SENSOR_VALUES["mff"]])
    (message,) = [m for m in domain_violations(batch) if "below -2" in m]
    assert message.startswith("V[1] (1 of 3 rows) has values below -2") and "in row 1" in message
    with pytest.raises(ValueError, match="finite values at the 100 sensors"):
        domain_violations(np.zeros(99))


