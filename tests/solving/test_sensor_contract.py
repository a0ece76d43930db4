"""The tolerance contract on sensor values, network answers included: their potential is
the spline through them, so the truth is that spline's trajectory. On potentials no
calibration saw (fresh draws of both generators, seed 9093, and out-of-distribution
potentials, seed 9094, all given as their 100 sensor values), at random times (short
horizons too), every answer ``solve_many`` or ``solve`` accepts meets tol, networks answer
some, and the same test fails when every shipped factor (``factors_sensors``, the early
and finer-grid ones included) is multiplied by 0.01. Only the cost test is opened
(``open_costs``)."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample
from nh_operators.potentials import ood_potentials

SEED = 9093
TOLS = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5)


@pytest.fixture(scope="module")
def fresh():
    """{name: sensor values (N, 100)} of each distribution."""
    out = {"ood": np.stack([p.V(nh.SENSORS) for p in ood_potentials(200, SEED + 1)])}
    for name, kwargs in (("alg1", {}), ("paper", {"normalization": "batch", "pool": 150})):
        space = nh.BoundedPotentialSpace(seed=SEED + len(out), **kwargs)
        out[name] = space.potentials(space.random(120)).V(nh.SENSORS)
    return out


def _times(rng):
    horizon = 2.0 if rng.random() < 0.5 else float(np.exp(rng.uniform(np.log(0.05), 0.0)))
    return np.sort(rng.uniform(0.0, horizon, int(rng.integers(1, 40))))


def _answers(fresh, rng):
    """(true L_tot, tol, neural) of every answer: each set's rows at one random set of
    times per tolerance, and 8 single solves at their own times."""
    rows = []
    for V in fresh.values():
        for tol in TOLS:
            t = _times(rng)
            q_ref, p_ref = nh.integrate_sensors(V, t, substeps=512, check_resolution=False)
            sol = nh.solve_many(V, t, tol=tol)
            true = loss_per_sample(sol.q, sol.p, q_ref, p_ref)["L_tot"]
            rows += [(e, tol, n) for e, n in zip(true, sol.neural)]
            for i in range(8):
                ti = _times(rng)
                one = nh.solve(V[i], ti, tol=tol)
                q_ref, p_ref = nh.integrate_sensors(V[i:i + 1], ti, substeps=512,
                                                    check_resolution=False)
                rows.append((float(loss_per_sample(one.q, one.p, q_ref[0], p_ref[0])["L_tot"]),
                             tol, one.kind == "neural"))
    return np.array(rows, dtype=np.float64)


def test_every_accepted_answer_on_sensor_values_meets_tol(fresh, open_costs):
    open_costs()
    rows = _answers(fresh, np.random.default_rng(SEED))
    true, tol, neural = rows[:, 0], rows[:, 1], rows[:, 2].astype(bool)
    assert np.all(true <= tol), f"worst true / tol {np.max(true / tol):.3g}"
    assert neural.sum() >= 100, f"{neural.sum()} network answers"


def test_sensor_factors_far_too_small_are_caught(fresh, open_costs):
    open_costs(factor_scale=0.01)
    rows = _answers(fresh, np.random.default_rng(SEED))
    true, tol, neural = rows[:, 0], rows[:, 1], rows[:, 2].astype(bool)
    assert np.any(true[neural] > tol[neural])
