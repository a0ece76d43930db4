"""The exact trajectories of the SHO and MFF from any state."""

import numpy as np
import pytest

import nh_operators as nh


@pytest.mark.parametrize("name", ["sho", "mff"])
def test_exact_from_a_state_on_the_orbit_is_the_same_orbit_shifted_in_time(name):
    pot = nh.PHYSICAL_POTENTIALS[name]
    t = np.linspace(0.0, 7.0, 141)
    for s in (0.13, 0.61, 1.37):
        q_s, p_s = pot.exact(np.array(s))
        q, p = pot.exact(t, float(q_s), float(p_s))
        q_ref, p_ref = pot.exact(t + s)
        np.testing.assert_allclose(q, q_ref, rtol=0, atol=1e-12)
        np.testing.assert_allclose(p, p_ref, rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ["sho", "mff"])
def test_exact_from_a_state_keeps_its_energy_and_starts_there(name):
    pot = nh.PHYSICAL_POTENTIALS[name]
    q0, p0 = 0.3, -1.1
    t = np.linspace(0.0, 5.0, 101)
    q, p = pot.exact(t, q0, p0)
    assert (q[0], p[0]) == pytest.approx((q0, p0), abs=1e-15)
    energy = 0.5 * p**2 + pot.V(q)
    np.testing.assert_allclose(energy, 0.5 * p0**2 + pot.V(q0), rtol=0, atol=1e-12)
