"""Stability at the extremes: steep walls, near-flat potentials, deep wells, kinks,
float32 against float64, batch 1 against batch 100,000, and the warnings."""

import copy
import json
import math
import re
import tracemalloc
import warnings

import numpy as np
import pytest
import torch
from scipy.interpolate import CubicSpline
from solver_helpers import generator_sensor_values

import nh_operators as nh
from nh_operators.evaluation import (
    ENERGY_BOUNDS,
    EXTREME_CASES,
    case_properties,
    energy_error,
    extreme_potentials,
    extreme_reference,
    loss_per_sample,
    stability_markdown,
    stability_table,
)
from nh_operators.models import cast_network
from nh_operators.potentials import (
    OutOfDomainWarning,
    domain_violations,
)
from nh_operators.solvers import (
    ENERGY_DRIFT_TOL,
    METHODS,
    RESOLUTION_FRACTION,
    STABILITY_LIMITS,
    ResolutionWarning,
    integrate,
    integrate_sensors,
    paper_rk4,
    reference_solve,
)

POTS = extreme_potentials()
SENSOR_VALUES = {name: pot.V(nh.SENSORS) for name, pot in POTS.items()}
SMOOTH = ["steep_wall", "near_flat", "deep_well", "smff_200"]
TINY = {"deeponet": dict(hidden_size=16, hidden_layers=2, branches=4),
        "traonet": dict(d_model=16, nhead=2, num_layers=1, dim_feedforward=32)}


def quiet(call, *args, **kwargs):
    """Run a solver with its warnings recorded: (result, list of warning messages)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call(*args, **kwargs)
    return result, [str(w.message) for w in caught if issubclass(w.category, ResolutionWarning)]


def tiny(name, seed=0):
    torch.manual_seed(seed)
    return nh.build_model(name, "cpu", **TINY[name])


@pytest.fixture(scope="module")
def references():
    return {name: extreme_reference(name) for name in POTS}


# ------------------------------------------------------------------------ the cases


def test_cases_are_bounded_and_have_their_stated_property():
    assert list(POTS) == list(EXTREME_CASES) == ["steep_wall", "near_flat", "deep_well", "mff",
                                                 "smff_200"]
    q = np.linspace(0.0, 1.0, 100_001)
    for name, pot in POTS.items():
        assert nh.check_bounded(pot.V).shape == (100,), name
        with np.errstate(over="ignore"):  # every V and dV stays finite far outside [0, 1]
            far = np.array([-1e3, -1.0, 2.0, 1e3])
            assert np.all(np.isfinite(pot.V(far))) and np.all(np.isfinite(pot.dV(far))), name
    # steep wall: the slope at q = 0 measured by a difference quotient, not the formula
    slope = (POTS["steep_wall"].V(1e-7) - POTS["steep_wall"].V(0.0)) / 1e-7
    assert slope == pytest.approx(-200.0, rel=1e-4) and abs(slope) >= 100
    assert POTS["near_flat"].V(q).min() >= 1.99 >= 1.9
    assert POTS["deep_well"].V(q).min() == pytest.approx(-100.0, abs=1e-9)
    assert POTS["deep_well"].V(q).min() <= -20
    # kinks: the force jumps from -4 to 4 at q = 1/2 (MFF) or within 1/40 of it (SMFF)
    for name, width in (("mff", 1e-9), ("smff_200", 0.025)):
        forces = POTS[name].dV(np.array([0.5 - width, 0.5 + width]))
        np.testing.assert_allclose(forces, [-4.0, 4.0], atol=5e-3)
    props = case_properties(POTS["steep_wall"])
    assert props["dV0"] == pytest.approx(-200.0) and props["sensor_curvature"] > 7000


def test_exact_solutions_match_the_reference_solver():
    for name in ("near_flat", "deep_well", "mff"):
        exact = POTS[name].exact(nh.TIMES)
        q, p = reference_solve(POTS[name], nh.TIMES)
        assert loss_per_sample(q, p, *exact)["L_tot"] <= 1e-18, name  # measured ≤ 1.1e-19
        assert energy_error(*exact, POTS[name]) <= 1e-13, name
        assert extreme_reference(name)[0] is not None
    assert extreme_reference("near_flat", [2.0])[0][0] == pytest.approx(0.0779, abs=1e-4)
    with pytest.raises(KeyError, match="unknown case 'sho'"):
        extreme_reference("sho")


@pytest.mark.parametrize("name", ["steep_wall", "smff_200"])
def test_solved_references_are_trustworthy(name, references):
    q_ref, p_ref = references[name]
    assert energy_error(q_ref, p_ref, POTS[name]) <= 1e-10
    # an independent method: Yoshida-8 with 16 steps per interval on the formula
    q, p = integrate(POTS[name], nh.TIMES, "yoshida8", 16)
    assert loss_per_sample(q, p, q_ref, p_ref)["L_tot"] <= 1e-12
    if name == "smff_200":  # and SMFF with α = 200 is close to MFF
        assert loss_per_sample(q_ref, p_ref, *POTS["mff"].exact(nh.TIMES))["L_tot"] < 1e-4


# ------------------------------------------------------------------ classical solvers

SENSOR_METHODS = {
    "rk4_4": lambda V, t: integrate_sensors(V, t, "rk4", 4),
    "rk4_16": lambda V, t: integrate_sensors(V, t, "rk4", 16),
    "yoshida8_4": lambda V, t: integrate_sensors(V, t, "yoshida8", 4),
    "yoshida8_16": lambda V, t: integrate_sensors(V, t, "yoshida8", 16),
    "paper_rk4": paper_rk4,
}


@pytest.fixture(scope="module")
def table():
    return stability_table(SENSOR_METHODS)


def test_sensor_solvers_are_finite_with_bounded_energy_error(table):
    assert set(table) == set(EXTREME_CASES)
    for case, row in table.items():
        for method, entry in row.items():
            assert entry["error"] is None and entry["finite"], (case, method)
        for method in ("rk4_16", "yoshida8_16"):
            assert row[method]["energy_error"] <= ENERGY_BOUNDS["sensors_16"], (case, method)
            assert row[method]["warnings"] == [], (case, method)
    # the steep wall is not resolved by the sensors: more steps do not help
    steep = table["steep_wall"]
    assert steep["rk4_16"]["L_tot"] > 1e-4 and steep["yoshida8_16"]["L_tot"] > 1e-4
    assert table["near_flat"]["rk4_16"]["L_tot"] < 1e-25
    # RK4 at 4 steps fails on the deep well, and says so
    deep = table["deep_well"]["rk4_4"]
    assert deep["L_tot"] > 1 and any("drifted by" in w for w in deep["warnings"])
    assert table["deep_well"]["rk4_16"]["L_tot"] < 1e-5


@pytest.mark.parametrize("name", list(POTS))
def test_exact_potential_solvers_are_finite_with_bounded_energy_error(name, references):
    for method, key in (("rk4", "rk4_exact_16"), ("yoshida8", "yoshida8_exact_16")):
        (q, p), messages = quiet(integrate, POTS[name], nh.TIMES, method, 16)
        assert np.all(np.isfinite(q)) and np.all(np.isfinite(p))
        if name == "mff":  # the kink: first order, and a warning says so
            assert len(messages) == 1 and "dV jumps by 8 near q = 0.500" in messages[0]
            assert loss_per_sample(q, p, *references[name])["L_tot"] > 1e-6
        else:
            assert messages == []
            assert energy_error(q, p, POTS[name]) <= ENERGY_BOUNDS[key], (name, method)
    # even at one step per interval, where the warnings fire, values stay finite
    for method in ("rk4", "yoshida8"):
        (q, p), _ = quiet(integrate, POTS[name], nh.TIMES, method, 1)
        assert np.all(np.isfinite(q)) and np.all(np.isfinite(p))


@pytest.mark.parametrize("name", ["steep_wall", "deep_well", "near_flat"])
def test_symplectic_energy_error_does_not_grow(name):
    t = np.linspace(0.0, 20.0, 991)
    spline = CubicSpline(nh.SENSORS, SENSOR_VALUES[name])
    errors = {}
    for method in ("yoshida8", "rk4"):
        (q, p), _ = quiet(integrate_sensors, SENSOR_VALUES[name], t, method, 4)
        e = np.abs(0.5 * p**2 + spline(q) - nh.V0)
        errors[method] = e[t <= 2].max(), e[t >= 18].max()
    early, late = errors["yoshida8"]
    assert late <= 1.5 * early + 1e-14
    if name != "near_flat":  # the contrast: RK4 drifts
        assert errors["rk4"][1] > 5 * errors["rk4"][0]


# ---------------------------------------------------------------------- the warnings


def _limit(method):
    """Largest h ω with a stable step of q'' = -ω² q, by bisection on the step matrix."""
    def unstable(x):
        if METHODS[method] is None:
            a = np.array([[0.0, x], [-x, 0.0]])
            m = sum(np.linalg.matrix_power(a, k) / math.factorial(k) for k in range(5))
        else:
            m = np.eye(2)
            for w in METHODS[method]:
                kick = np.array([[1.0, 0.0], [-0.5 * x * w, 1.0]])
                m = kick @ np.array([[1.0, x * w], [0.0, 1.0]]) @ kick @ m
        return np.abs(np.linalg.eigvals(m)).max() > 1 + 1e-12

    x = next(v for v in np.arange(0.01, 4.0, 0.01) if unstable(v))
    lo, hi = x - 0.01, x
    for _ in range(40):
        lo, hi = (lo, (lo + hi) / 2) if unstable((lo + hi) / 2) else ((lo + hi) / 2, hi)
    return lo


@pytest.mark.parametrize("method", list(METHODS))
def test_stability_limits(method):
    assert STABILITY_LIMITS[method] == pytest.approx(_limit(method), abs=1e-4)


@pytest.mark.parametrize("name", ["steep_wall", "deep_well"])
@pytest.mark.parametrize("method", ["rk4", "yoshida8"])
def test_resolution_warning_names_the_fix(name, method):
    V = SENSOR_VALUES[name]
    _, messages = quiet(integrate_sensors, V, nh.TIMES, method, 1)
    curvature = [m for m in messages if "too coarse for the curvature of V" in m]
    assert len(curvature) == 1
    need = int(re.search(r"use substeps >= (\d+)", curvature[0]).group(1))
    x = float(re.search(r"h·sqrt\(max\|V''\|\) = ([\d.]+)", curvature[0]).group(1))
    assert x > RESOLUTION_FRACTION * STABILITY_LIMITS[method]
    ratio = x / (RESOLUTION_FRACTION * STABILITY_LIMITS[method])  # x printed to 3 digits
    assert ratio * 0.99 <= need < ratio * 1.01 + 1
    _, messages = quiet(integrate_sensors, V, nh.TIMES, method, need)
    assert not [m for m in messages if "curvature" in m]
    _, messages = quiet(integrate_sensors, V, nh.TIMES, method, 16)
    assert messages == []
    # on the formula too (its curvature probed on a fine grid)
    _, messages = quiet(integrate, POTS[name], nh.TIMES, method, 1)
    assert any("too coarse for the curvature of " + name in m for m in messages)


def test_energy_warning_names_the_fix():
    V = SENSOR_VALUES["deep_well"]
    _, messages = quiet(integrate_sensors, V, nh.TIMES, "rk4", 4)
    assert len(messages) == 1 and "drifted by 0.2" in messages[0]
    need = int(re.search(r"about (\d+) substeps", messages[0]).group(1))
    assert 5 <= need <= 12
    _, messages = quiet(integrate_sensors, V, nh.TIMES, "rk4", need)
    assert messages == []


def test_batches_name_the_rows():
    V = np.stack([SENSOR_VALUES["near_flat"], SENSOR_VALUES["steep_wall"],
                  SENSOR_VALUES["mff"], SENSOR_VALUES["deep_well"]])
    _, messages = quiet(integrate_sensors, V, nh.TIMES, "rk4", 1)
    assert "curvature of V[1, 3]:" in messages[0]
    pot = nh.BoundedPotential([0.0, 0.004, 0.5, 0.996, 1.0], [2.0, -2.0, -2.0, -2.0, 2.0])
    _, messages = quiet(integrate, pot, nh.TIMES, "rk4", 1)
    assert "too coarse for the curvature of V:" in messages[0]


def test_physical_potentials_warn_only_for_the_kink():
    for name, pot in nh.PHYSICAL_POTENTIALS.items():
        for method, substeps in (("rk4", 1), ("rk4", 4), ("yoshida8", 4)):
            _, messages = quiet(integrate_sensors, pot.V(nh.SENSORS), nh.TIMES, method, substeps)
            assert messages == [], (name, method, substeps)
            _, messages = quiet(integrate, pot, nh.TIMES, method, substeps)
            if name == "mff":  # the kink, on the formula (and at one step, the drift)
                assert "dV jumps by 8 near q = 0.500" in messages[0]
                assert len(messages) == 1 + (substeps == 1), messages
            else:
                assert messages == [], (name, method, substeps)


def test_generator_potentials_raise_no_warning():
    V = generator_sensor_values()
    runs = [("rk4", 1), ("rk4", 2), ("rk4", 4), ("yoshida4", 2), ("yoshida8", 2), ("yoshida8", 4)]
    with warnings.catch_warnings():
        warnings.simplefilter("error", ResolutionWarning)
        for method, substeps in runs:
            integrate_sensors(V, nh.TIMES, method, substeps)
        paper_rk4(V, nh.TIMES)
    assert ENERGY_DRIFT_TOL["cubic"] == 0.1


# -------------------------------------------------------------------- neural networks


def _neural(net):
    def method(V, t):
        for message in domain_violations(V):
            warnings.warn(message, OutOfDomainWarning)
        return nh.predict(net, V, t)

    return method


@pytest.mark.parametrize("name", sorted(TINY))
def test_tiny_networks_are_finite_and_warn_out_of_domain(name):
    result = stability_table({name: _neural(tiny(name))})
    for case, row in result.items():
        entry = row[name]
        assert entry["error"] is None and entry["finite"], case
        warned = [w for w in entry["warnings"] if w.startswith("OutOfDomainWarning")]
        assert bool(warned) == (case in ("steep_wall", "near_flat", "deep_well")), case


def test_float32_against_float64():
    V = np.stack(list(SENSOR_VALUES.values()))
    for name in sorted(TINY):
        net = tiny(name)
        q32, p32 = nh.predict(net, V, nh.TIMES)
        q64, p64 = nh.predict(cast_network(copy.deepcopy(net), torch.float64), V, nh.TIMES)
        scale = max(np.abs(q64).max(), np.abs(p64).max(), 1.0)
        np.testing.assert_allclose(q32, q64, rtol=0, atol=1e-5 * scale)
        np.testing.assert_allclose(p32, p64, rtol=0, atol=1e-5 * scale)
    # classical solvers compute in float64 whatever they are given
    V32 = V.astype(np.float32)
    (q, p), _ = quiet(integrate_sensors, V32, nh.TIMES, "rk4", 4)
    (q64, p64), _ = quiet(integrate_sensors, V32.astype(np.float64), nh.TIMES, "rk4", 4)
    assert q.dtype == p.dtype == np.float64
    np.testing.assert_array_equal(q, q64)
    np.testing.assert_array_equal(p, p64)


# ----------------------------------------------------------------------- batch sizes

#: Peak traced memory of integrate_sensors over its output size (q and p): the spline
#: coefficients (N, 99, 4) are held three times while built; measured 6.4 at 100,000 rows.
MEMORY_MULTIPLE = 8.0


def _batch_vs_single(n):
    base = np.stack([SENSOR_VALUES[name] for name in SMOOTH])
    V = np.tile(base, (n // len(base), 1))
    (q1, p1), _ = quiet(integrate_sensors, base, nh.TIMES, "rk4", 1)
    tracemalloc.start()
    try:
        (q, p), _ = quiet(integrate_sensors, V, nh.TIMES, "rk4", 1)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    for i in range(len(base)):
        np.testing.assert_array_equal(q[i::len(base)], np.broadcast_to(q1[i], (n // 4, 100)))
        np.testing.assert_array_equal(p[i::len(base)], np.broadcast_to(p1[i], (n // 4, 100)))
    assert peak <= MEMORY_MULTIPLE * (q.nbytes + p.nbytes)


def test_batch_of_10_000_equals_batch_1_in_bounded_memory():
    _batch_vs_single(10_000)


@pytest.mark.slow
def test_batch_of_100_000_equals_batch_1_in_bounded_memory():
    _batch_vs_single(100_000)


def test_predict_on_100_000_rows_feeds_at_most_batch_size():
    net = tiny("deeponet")
    base = np.stack(list(SENSOR_VALUES.values()))
    V = np.tile(base, (20_000, 1))
    sizes = []
    hook = net.register_forward_pre_hook(lambda _, args: sizes.append(args[0][0].shape[0]))
    try:
        q, p = nh.predict(net, V, nh.TIMES, batch_size=1000)
    finally:
        hook.remove()
    assert max(sizes) == 1000 and len(sizes) == 100 and q.shape == (100_000, 100)
    single = [nh.predict(net, base[i], nh.TIMES) for i in range(len(base))]
    for i, (qi, pi) in enumerate(single):  # float32 matmuls may block differently
        np.testing.assert_allclose(q[i::len(base)], np.broadcast_to(qi, (20_000, 100)), atol=1e-5)
        np.testing.assert_allclose(p[i::len(base)], np.broadcast_to(pi, (20_000, 100)), atol=1e-5)


# --------------------------------------------------------------- table and markdown


def test_table_is_json_and_records_errors_and_warnings(table):
    def refuses(V, t):
        raise RuntimeError("no")

    def nan(V, t):
        return np.full((len(V), len(t)), np.nan), np.zeros((len(V), len(t)))

    extra = stability_table({"refuses": refuses, "nan": nan}, cases=["mff"])
    assert extra["mff"]["refuses"]["error"] == "RuntimeError: no"
    assert extra["mff"]["nan"] == {"finite": False, "L_tot": None, "energy_error": None,
                                   "warnings": [], "error": None}
    json.dumps(table, allow_nan=False)
    text = stability_markdown(table)
    assert text.startswith("## Stability at the extremes")
    assert "| steep_wall |" in text and "ResolutionWarning" in text
    assert "**deep_well**" in text and "min V = -100" in text
    assert "error" in stability_markdown(extra)
