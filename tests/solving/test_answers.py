"""Answers that say what they are (issue 42): ``converged``, ``truth``, a short ``reason``
with the per-network details in ``candidates``, unreachable tolerances on kinks (MFF's
and a formula's), and 2-D times refused."""

import warnings

import numpy as np
import pytest
from calibration_helpers import fake_calibration, use_calibration

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample
from nh_operators.solvers import reference_solve
from nh_operators.solving import many as many_module
from nh_operators.solving.answers import Reference, Truth, Verdict
from nh_operators.solving.loader import load
from nh_operators.solving.network_pass import neural_solve

#: A kink at q = 0.3: V = 2 + 4 (|q − 0.3| − 0.3 − 0.4 q), V(0) = V(1) = 2.
KINK = "2 + 4*(abs(q-0.3) - 0.3 - 0.4*q)"
SHO = nh.PHYSICAL_POTENTIALS["sho"]
T = np.array([1.7, 0.05, 0.6, 2.0, 1.1])


def _true(sol, name, t):
    """The true L_tot against a physical potential's exact or reference trajectory."""
    pot = nh.PHYSICAL_POTENTIALS[name]
    exact = pot.exact(t)
    q, p = exact if exact is not None else reference_solve(pot, t)
    return float(loss_per_sample(sol.q, sol.p, q, p)["L_tot"])


@pytest.mark.parametrize("name", sorted(nh.PHYSICAL_POTENTIALS))
def test_the_default_tol_is_certified_on_every_physical_potential(name):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning at all: the default is reached
        sol = nh.solve(name, nh.TIMES)
    assert sol.converged and sol.error_estimate <= nh.DEFAULT_TOL
    assert sol.truth == Truth(Reference.EXACT, 1.0) and sol.truth.certain
    assert _true(sol, name, nh.TIMES) <= nh.DEFAULT_TOL


# times past each kink; short for the formula, whose first solve runs in Python
@pytest.mark.parametrize(("potential", "t"), [("mff", nh.TIMES), (KINK, np.array([0.25, 0.5]))])
def test_an_unreachable_tol_on_a_kink_returns_converged_false_with_a_warning(potential, t):
    with pytest.warns(RuntimeWarning, match="tolerance 1e-12 not reached"):
        sol = nh.solve(potential, t, tol=1e-12)
    assert not sol.converged and sol.error_estimate > 1e-12 and sol.method == "rk4"
    assert "not converged" in sol.reason and "1e-12" in sol.reason
    if potential == "mff":  # the finest answer, its estimate above its true error
        assert _true(sol, potential, t) <= sol.error_estimate


@pytest.mark.parametrize("potential", ["mff", KINK])
@pytest.mark.parametrize("tol", [1e-4, 1e-8, 1e-12])
def test_no_answer_over_tol_without_converged_false_on_kinks(potential, tol):
    rng = np.random.default_rng(42)
    for _ in range(2):
        t = np.sort(rng.uniform(0.0, 2.0, int(rng.integers(2, 12))))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            sol = nh.solve(potential, t, tol=tol)
        warned = any(issubclass(w.category, RuntimeWarning) for w in caught)
        assert sol.converged == (sol.error_estimate <= tol) and sol.converged != warned
        if sol.converged and potential == "mff":  # MFF's exact trajectory is known
            assert _true(sol, potential, t) <= tol


def test_sensor_values_are_measured_against_their_spline():
    """MFF's kink between sensors: its spline's trajectory is 1.5e-8 from MFF's own, so an
    answer converged at 1e-8 against the spline misses MFF's trajectory."""
    mff = nh.PHYSICAL_POTENTIALS["mff"]
    V = mff.V(nh.SENSORS)
    sol = nh.solve(V, nh.TIMES, tol=1e-8)
    assert sol.converged and sol.truth == Truth(Reference.SPLINE, 1.0)
    assert str(sol.truth) == "sensor spline"
    q_s, p_s = nh.integrate_sensors(V[None], nh.TIMES, substeps=512, check_resolution=False)
    assert loss_per_sample(sol.q, sol.p, q_s[0], p_s[0])["L_tot"] <= 1e-8
    q, p = mff.exact(nh.TIMES)
    assert loss_per_sample(sol.q, sol.p, q, p)["L_tot"] > 1e-8


def test_a_network_answer_states_its_calibrated_quantile():
    quantile = load("deeponet-alg1").calibration.info["quantile"]
    assert quantile == 0.999
    with pytest.warns(UserWarning, match="exceeds tol"):
        tight = nh.solve("sho", T, tol=1e-9, method="deeponet-alg1")
    assert not tight.converged and "not converged" in tight.reason
    assert tight.truth == Truth(Reference.EXACT, 0.999) and not tight.truth.certain
    assert str(tight.truth) == "exact potential, 99.9 % quantile"
    loose = nh.solve(SHO.V(nh.SENSORS), T, tol=1.0, method="deeponet-alg1")
    assert loose.converged and loose.truth == Truth(Reference.SPLINE, 0.999)


def test_reason_is_short_and_candidates_carry_the_details(monkeypatch):
    plain = nh.solve("sho", T, tol=1e-6)
    at_rest = [n for n in nh.available_pretrained() if not load(n).reads_state]
    assert plain.reason.startswith("no network expected to be cheaper")
    assert len(plain.reason) < 100 and "\n" not in plain.reason
    assert sorted(c.name for c in plain.candidates) == sorted(at_rest)
    assert {c.verdict for c in plain.candidates} == {Verdict.NOT_CHEAPER}
    first = plain.candidates[0]
    cal = load(first.name).calibration
    expected, share, t_cls = cal.expected_seconds(1e-6, "formula", batched=False,
                                                  horizon=first_horizon(T))
    assert (first.share, first.expected_seconds, first.classical_seconds) == (
        share, expected, t_cls)
    # a network made cheap is answered by, the others are listed as not tried or dearer
    use_calibration(monkeypatch, "deeponet-alg1", fake_calibration(1.0, 1e-5))
    _, _, estimate = neural_solve("deeponet-alg1", SHO, "exact V", T)
    loose = nh.solve("sho", T, tol=10 * estimate)
    verdicts = {c.name: c.verdict for c in loose.candidates}
    assert loose.kind == "neural" and verdicts["deeponet-alg1"] == Verdict.ANSWERED
    assert loose.reason == "deeponet-alg1 was expected cheapest and its estimate met tol"
    tight = nh.solve("sho", T, tol=estimate / 10)
    assert {c.name: c.verdict for c in tight.candidates}["deeponet-alg1"] == Verdict.REJECTED
    assert tight.reason.startswith("deeponet-alg1's estimate") and len(tight.reason) < 100
    far = nh.solve("sho", [0.5, 3.0], tol=10 * estimate)
    assert {c.name: c.verdict for c in far.candidates}["deeponet-alg1"] == \
        Verdict.OUTSIDE_TIMES
    assert nh.solve("sho", T).candidates == ()


def first_horizon(t):
    from nh_operators.solving.costs import horizon_key

    return horizon_key(np.asarray(t))


@pytest.mark.parametrize("shape", [(2, 3), (1, 5)])
def test_two_dimensional_times_are_refused(shape):
    t = np.linspace(0.1, 1.0, int(np.prod(shape))).reshape(shape)
    with pytest.raises(ValueError, match=rf"one-dimensional.*{shape}.*solve_many"):
        nh.solve("sho", t, tol=1e-6)


def test_solve_many_says_per_row_what_converged_and_against_what(monkeypatch):
    V = np.stack([SHO.V(nh.SENSORS), nh.PHYSICAL_POTENTIALS["double_well"].V(nh.SENSORS)])
    ok = nh.solve_many(V, T, tol=1e-8)
    assert ok.converged.tolist() == [True, True]
    assert [str(x) for x in ok.truth] == ["sensor spline"] * 2
    assert ok.records[1]["converged"] and ok.records[1]["truth"] == Truth(Reference.SPLINE)
    # a cap the solver cannot meet tol under: the finest answers, False where missed
    monkeypatch.setattr(many_module, "MAX_SUBSTEPS", 4)
    with pytest.warns(RuntimeWarning, match="not reached"):
        capped = nh.solve_many(V, T, tol=1e-12)
    assert not capped.converged.any()
    np.testing.assert_array_equal(capped.converged, capped.error_estimate <= 1e-12)


def test_solve_many_lists_and_forced_networks_say_what_they_are():
    with pytest.warns(RuntimeWarning, match="not reached"):
        rows = nh.solve_many(["mff", "sho"], nh.TIMES, tol=1e-12)
    assert rows.converged.tolist() == [False, True]
    assert [t.reference for t in rows.truth] == [Reference.EXACT] * 2
    V = np.stack([SHO.V(nh.SENSORS)] * 2)
    with pytest.warns(UserWarning, match="exceeds tol 1e-09 on 2 rows"):
        forced = nh.solve_many(V, T, tol=1e-9, method="deeponet-alg1")
    assert not forced.converged.any()
    assert set(forced.truth) == {Truth(Reference.SPLINE, 0.999)}
    loose = nh.solve_many(V, T, tol=1.0, method="deeponet-alg1")
    assert loose.converged.all() and loose.neural.all()
