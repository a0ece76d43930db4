"""The contract measurement on a few inputs: its bookkeeping and the contract itself."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.data import generate_dataset
from nh_operators.solving import contract_cases, measure_contract, network_estimates


@pytest.fixture(scope="module")
def cases():
    return contract_cases(generate_dataset(12, seed=11, progress=False), 12, 4, seed=2)


def test_cases_carry_their_truth(cases):
    assert [c.group for c in cases].count("test") == 12
    assert [c.group for c in cases].count("ood") == 4 + len(nh.PHYSICAL_POTENTIALS)
    sho = cases[-len(nh.PHYSICAL_POTENTIALS)]
    q, p = nh.PHYSICAL_POTENTIALS["sho"].exact(sho.t)
    np.testing.assert_allclose(sho.q, q, atol=1e-10)
    np.testing.assert_allclose(sho.p, p, atol=1e-9)
    first = cases[0]
    assert first.t.size == first.q.size and set(first.t) <= set(nh.TIMES)
    with pytest.raises(ValueError, match="n_test"):
        contract_cases(generate_dataset(3, seed=1, progress=False), 4, 0)


def test_solve_meets_the_contract_on_these_inputs(cases):
    rows = measure_contract(cases, [1e-4, 1e-8])
    assert [(r["group"], r["tol"]) for r in rows] == [
        ("test", 1e-4), ("test", 1e-8), ("ood", 1e-4), ("ood", 1e-8)]
    for r in rows:
        assert r["met"] == 1.0 and r["worst"] <= 1.0
        assert r["auto_s"] > 0 and r["classical_s"] > 0
        assert r["saved"] == pytest.approx(1 - r["auto_s"] / r["classical_s"])


def test_network_estimates_count_false_acceptances(cases):
    rows = network_estimates(cases, ["deeponet-alg1"], [1e3, 1e-12])
    loose, tight = rows[0], rows[1]
    assert loose["accepted"] == 1.0 and loose["false"] == 0.0  # everything is below 1e3
    assert tight["accepted"] == 0.0 and np.isnan(tight["false"])
    assert loose["median_true"] > 1e-5  # DeepONet is nowhere near exact
