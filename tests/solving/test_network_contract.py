"""The tolerance contract with the real shipped calibrations, network answers included
(issue 24): on potentials no calibration or tuning saw (seed 9091), every answer that
``solve`` or ``solve_many`` accepts — a network's or the classical solver's — meets tol
against the exact reference, networks do answer some of them, and the same test fails
when the shipped calibration factors are multiplied by 0.01. The factors are the shipped
ones; only the cost test is opened (the ``open_costs`` fixture of ``conftest.py``), since
on this CPU ``auto`` never expects a network to be cheaper.
"""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample

SEED = 9091
#: Tolerances where networks answer (at 1e-6 only the ones that compute the orbit's shape).
TOLS = (3e-1, 1e-1, 3e-2, 1e-2, 1e-3, 1e-6)


@pytest.fixture(scope="module")
def fresh():
    """A fresh draw of each distribution, labelled exactly: {name: dataset}."""
    out = {}
    for name, kwargs in (("alg1", {}), ("paper", {"normalization": "batch", "pool": 500})):
        out[name] = nh.generate_dataset(120, SEED, progress=False, **kwargs)
    return out


def _answers(fresh, rng):
    """(true L_tot, tol, neural) of every answer of solve_many and solve: each
    distribution's 120 potentials at one random set of times per tolerance, and 10
    single solves at their own times."""
    rows = []
    for ds in fresh.values():
        pots = ds.potentials()
        for tol in TOLS:
            t = rng.uniform(0.0, 2.0, int(rng.integers(1, 40)))
            q_ref, p_ref = nh.reference_solve(pots, t)
            sol = nh.solve_many(pots, t, tol=tol)
            true = loss_per_sample(sol.q, sol.p, q_ref, p_ref)["L_tot"]
            rows += [(e, tol, n) for e, n in zip(true, sol.neural)]
            for i in range(10):
                ti = rng.uniform(0.0, 2.0, int(rng.integers(1, 20)))
                one = nh.solve(ds.potential(i), ti, tol=tol)
                q_ref, p_ref = nh.reference_solve(ds.potential(i), ti)
                rows.append((float(loss_per_sample(one.q, one.p, q_ref, p_ref)["L_tot"]), tol,
                             one.kind == "neural"))
    return np.array(rows, dtype=np.float64)


def test_every_accepted_answer_meets_tol_and_networks_answer_some(fresh, open_costs):
    open_costs()
    rows = _answers(fresh, np.random.default_rng(SEED))
    true, tol, neural = rows[:, 0], rows[:, 1], rows[:, 2].astype(bool)
    assert len(rows) == 2 * len(TOLS) * 130
    assert np.all(true <= tol), f"worst true / tol {np.max(true / tol):.3g}"
    # a test that never used a network could not fail on one
    assert neural.sum() >= 20, f"{neural.sum()} network answers"


def test_a_calibration_far_too_small_is_caught(fresh, open_costs):
    # the shipped factors cut 100×: the networks that compute the orbit's shape, the
    # cheapest, have estimates 60-440× their true error at the median, and cut 10× no
    # answer of theirs goes over tol here (measured); 10× sufficed before they shipped
    open_costs(factor_scale=0.01)
    rows = _answers(fresh, np.random.default_rng(SEED))
    true, tol, neural = rows[:, 0], rows[:, 1], rows[:, 2].astype(bool)
    assert np.any(true[neural] > tol[neural])
