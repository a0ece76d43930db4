"""The doubling does not stop where two levels agree by chance (found by issue 14's
horizon benchmark: a test-set potential, seed 42, index 8, from (0, 0) on [0, 2])."""

import numpy as np

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample
from nh_operators.potentials import BoundedPotentialSpace


def test_levels_agreeing_by_chance_are_not_accepted():
    space = BoundedPotentialSpace(seed=42)
    pot = space.potentials(space.random(10))[8]
    t = np.linspace(0, 2, 20)
    q16, p16 = nh.integrate(pot, t, substeps=16)
    q32, p32 = nh.integrate(pot, t, substeps=32)
    qr, pr = nh.reference_solve(pot, t)
    # 16 and 32 RK4 substeps: both about 2e-8 from the truth, but 6e-11 apart
    assert loss_per_sample(q32, p32, q16, p16)["L_tot"] < 1e-10
    assert loss_per_sample(q32, p32, qr, pr)["L_tot"] > 1e-8
    sol = nh.solve(pot, t, tol=1e-8)
    assert loss_per_sample(sol.q, sol.p, qr, pr)["L_tot"] <= sol.error_estimate <= 1e-8
    assert sol.tried[-1]["substeps"] > 32
