"""solve_many: row by row the same as solve, from any state, at any horizon (issue 14)."""

import numpy as np
import pytest
from calibration_helpers import use_calibration

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample
from nh_operators.solving import reads_state


@pytest.fixture(scope="module")
def scene(pots):
    rng = np.random.default_rng(14)
    V = pots.V(nh.SENSORS)
    # random bounded states: q0 anywhere, p0 within what the energy allows
    q0 = rng.uniform(0.05, 0.95, len(V))
    room = 2.0 - np.array([np.interp(q, nh.SENSORS, v) for q, v in zip(q0, V)])
    p0 = rng.choice([-1, 1], len(V)) * np.sqrt(2 * room * rng.uniform(0, 0.9, len(V)))
    return V, q0, p0


def test_rows_equal_solve_row_by_row(scene):
    V, q0, p0 = scene
    t = np.array([0.3, 1.7, 5.5, 1e4])
    many = nh.solve_many(V, t, q0=q0, p0=p0, tol=1e-8)
    assert many.q.shape == (len(V), 4) and set(many.methods) == {"rk4"}
    for i in range(len(V)):
        one = nh.solve(V[i], t, q0=q0[i], p0=p0[i], tol=1e-8)
        assert np.abs(one.q - many.q[i]).max() <= 1e-14
        assert np.abs(one.p - many.p[i]).max() <= 1e-14
        assert one.error_estimate == pytest.approx(many.error_estimate[i], rel=1e-12)
        assert many.records[i]["substeps"] == one.tried[-1]["substeps"]


def test_batched_bspline_per_row_times_and_the_state_zero(pots, reference):
    q_ref, p_ref, _ = reference
    t = np.broadcast_to(nh.TIMES, (len(pots), nh.TIMES.size))
    many = nh.solve_many(pots, t, tol=1e-8, method="classical")
    assert np.all(loss_per_sample(many.q, many.p, q_ref, p_ref)["L_tot"] <= 1e-8)
    one = nh.solve(pots[3], nh.TIMES, tol=1e-8, method="classical")
    assert np.abs(one.q - many.q[3]).max() <= 1e-14


def test_formulas_one_by_one_and_records():
    many = nh.solve_many(["8*(q-0.5)**2", "mff", "625/8*(q-0.2)**2*(q-0.8)**2"], [1.0, 3e5],
                         q0=[0.5, 0.0, 0.3], p0=[1.0, 0.0, 0.0], tol=1e-6)
    assert many.q.shape == (3, 2)
    assert [r["kind"] for r in many.records] == ["classical"] * 3
    assert many.records[1]["period"] == pytest.approx(2.0, abs=1e-12)
    q, p = nh.PHYSICAL_POTENTIALS["mff"].exact(np.array([1.0, 3e5]))
    assert loss_per_sample(many.q[1], many.p[1], q, p)["L_tot"] <= 1e-6


def test_auto_uses_networks_only_where_allowed(scene):
    V, q0, p0 = scene
    q0 = q0.copy()
    q0[::2] = 0.0
    p0 = np.where(q0 == 0.0, 0.0, p0)
    many = nh.solve_many(V, nh.TIMES, q0=q0, p0=p0, tol=1e-2)
    moved = q0 != 0.0
    # a moved row goes to the classical solver or to a network that reads a state
    # (cheaper on sensor values since the orbit runs compiled), never to a rest network
    assert all(m == "rk4" or reads_state(m) for m in set(many.methods[moved]))
    assert not any(reads_state(m) for m in set(many.methods[~moved]) - {"rk4"})
    assert np.all(many.error_estimate <= 1e-2)
    with pytest.raises(ValueError, match=r"trained from the state \(0, 0\) only; row 1"):
        nh.solve_many(V, nh.TIMES, q0=q0, p0=p0, method="deeponet")


def test_bad_rows_are_named(scene):
    V = scene[0]
    with pytest.raises(ValueError,
                       match=r"row 2: the state \(q0 = 0.5, p0 = 3\) has energy") as err:
        nh.solve_many(V, [1.0], q0=0.5, p0=[0, 0, 3.0] + [0] * (len(V) - 3))
    assert isinstance(err.value, nh.solvers.RowError) and err.value.row == 2
    with pytest.raises(ValueError, match=r"t must have shape \(M,\) or \(N, M\)"):
        nh.solve_many(V, np.zeros((2, 3)))


def test_solve_many_weighs_per_row_batched_costs_not_one_calls(monkeypatch):
    import dataclasses

    from nh_operators.solving import InputKind, load, ranking

    name, sensors = "phaseonet-paper", InputKind.SENSORS
    cal = load(name).calibration
    n = len(cal.classical_tols)
    # one call of the network costs more than one classical call, a batched row less
    classical = dict(cal.classical)
    classical[sensors] = dict(classical[sensors], full=np.full(n, 0.5),
                              batched=np.full(n, 1e-4))
    cal = dataclasses.replace(cal, neural_seconds=1.0, neural_seconds_batched=1e-6,
                              classical=classical)
    use_calibration(monkeypatch, name, cal)
    tol = 1e-2
    share = cal.acceptance_rate(tol, sensors)  # the input's kind
    assert share > 0.5
    single, _ = ranking.ranked(tol, sensors)
    batched, _ = ranking.ranked(tol, sensors, True)
    assert name not in [c[0] for c in single]
    (expected,) = [c[1] for c in batched if c[0] == name]
    assert expected == pytest.approx(1e-6 + (1 - share) * 1e-4)


def test_a_row_one_network_rejects_goes_on_to_the_next(monkeypatch):
    """An Algorithm-1 potential can lie in a -paper network's domain, whose estimate then
    rejects it; its -alg1 sibling, the next candidate, must still be tried (it was not:
    at tol 1e-3 on 10,000 Algorithm-1 rows 2 % went to phaseonet-alg1 instead of ~57 %).
    Here phaseonet-paper is made the cheapest candidate with an estimate that always
    fails, every network but the two PhaseONets too dear to try."""
    _calibrations(monkeypatch, {"phaseonet-paper": 1e-9, "phaseonet-alg1": 2e-9},
                  failing=("phaseonet-paper",))
    ds = nh.generate_dataset(30, seed=77, progress=False)
    V, tol = np.asarray(ds.V), 1e-2
    many = nh.solve_many(V, nh.TIMES, tol=tol)
    assert [(a["method"], a["accepted"]) for a in many.tried][0] == ("phaseonet-paper", 0)
    assert many.tried[1]["method"] == "phaseonet-alg1" and many.tried[1]["accepted"] >= 20
    assert set(many.methods[many.neural]) == {"phaseonet-alg1"}
    q_ref, p_ref = nh.integrate_sensors(V, nh.TIMES, substeps=256, check_resolution=False)
    assert np.all(loss_per_sample(many.q, many.p, q_ref, p_ref)["L_tot"] <= tol)
    # one call of solve tries one network only (no pilot tells it the share on such rows)
    i = int(np.flatnonzero(many.neural)[0])
    one = nh.solve(V[i], nh.TIMES, tol=tol)
    assert [(a["method"], a["accepted"]) for a in one.tried] == [
        ("phaseonet-paper", False), ("rk4", True)]


def test_a_pilot_stops_a_network_that_rejects_the_rows(monkeypatch):
    """A network offered 2 * PILOT rows or more answers at most PILOT of them first and
    goes on only if the share it accepted pays for its cost: one that rejects every row
    of the first eighth of its pilot rows is not run on the rest, nor on the rest of its
    pilot rows."""
    from nh_operators.solving import many

    monkeypatch.setattr(many, "PILOT", 8)
    _dear_classical(monkeypatch)
    _calibrations(monkeypatch, {"phaseonet-paper": 1e-9}, failing=("phaseonet-paper",))
    V = np.asarray(nh.generate_dataset(30, seed=78, progress=False, normalization="batch",
                                       pool=40).V)
    sol = nh.solve_many(V, nh.TIMES, tol=1e-2)
    (entry,) = sol.tried
    assert entry["method"] == "phaseonet-paper" and entry["rows"] == 1  # 8 // 8
    assert entry["accepted"] == 0 and "not worth its cost" in entry["stopped"]
    assert not sol.neural.any()


def test_the_pilot_orders_the_networks_by_what_they_accepted_there(monkeypatch):
    """With a pilot, the cheapest candidate by calibration no longer goes first: the
    candidates are tried on the pilot rows, and only one whose accepted rows there paid
    for it goes on. phaseonet-paper (ranked first, its estimate always failing) answers
    only the pilot; phaseonet-alg1 answers the rest."""
    from nh_operators.solving import many

    monkeypatch.setattr(many, "PILOT", 8)
    _dear_classical(monkeypatch)
    _calibrations(monkeypatch, {"phaseonet-paper": 1e-9, "phaseonet-alg1": 2e-9},
                  failing=("phaseonet-paper",))
    V = np.asarray(nh.generate_dataset(30, seed=77, progress=False).V)
    many_sol = nh.solve_many(V, nh.TIMES, tol=1e-2)
    first, second = many_sol.tried
    assert first["method"] == "phaseonet-alg1" and first["accepted"] >= 20
    # it accepted none of the first eighth of its pilot rows: stopped there
    assert second == {"method": "phaseonet-paper", "rows": 1, "accepted": 0,
                      "stopped": "accepted 0.0% of a pilot of 1 rows: not worth its cost"}
    assert set(many_sol.methods[many_sol.neural]) == {"phaseonet-alg1"}
    q_ref, p_ref = nh.integrate_sensors(V, nh.TIMES, substeps=256, check_resolution=False)
    assert np.all(loss_per_sample(many_sol.q, many_sol.p, q_ref, p_ref)["L_tot"] <= 1e-2)


def test_a_row_the_grid_estimate_refuses_is_estimated_again_on_the_finer_grid(monkeypatch):
    """phaseonet-paper's estimate on the grid is made to fail everywhere (factors 1e12);
    its finer look (solving/refine.py, calibrated on its own) still accepts rows, and
    every accepted answer meets tol against the sensor spline's trajectory."""
    _calibrations(monkeypatch, {"phaseonet-paper": 1e-9}, failing=("phaseonet-paper",),
                  grid_only=True)
    V = np.asarray(nh.generate_dataset(30, seed=79, progress=False, normalization="batch",
                                       pool=40).V)
    tol = 1e-4
    sol = nh.solve_many(V, nh.TIMES, tol=tol)
    assert sol.neural.sum() >= 20 and set(sol.methods[sol.neural]) == {"phaseonet-paper"}
    q_ref, p_ref = nh.integrate_sensors(V, nh.TIMES, substeps=256, check_resolution=False)
    assert np.all(loss_per_sample(sol.q, sol.p, q_ref, p_ref)["L_tot"] <= tol)
    # the estimate returned is the finer look's, calibrated with its own factors
    assert np.all(sol.error_estimate[sol.neural] <= tol)


def _dear_classical(monkeypatch, seconds=1.0):
    """Make the pilot's measured classical cost ``seconds`` per row (its probe rows are
    still solved): with a pilot of 8 rows, a network's fixed cost per call would otherwise
    decide, not what it accepted; and forget the costs and shares measured before."""
    from nh_operators.solving import costs, many

    probe = many._classical_probe
    monkeypatch.setattr(many, "_classical_probe", lambda *a: (probe(*a), seconds)[1])
    monkeypatch.setattr(costs, "_MEASURED", {})  # nothing remembered from other tests


def _calibrations(monkeypatch, costs, failing=(), grid_only=False):
    """Patch every shipped calibration: each network's estimate meets every tolerance on
    its whole calibration set (share 1), costs ``costs[name]`` seconds (1e3 where not
    given), and the estimates of the networks in ``failing`` always fail (factors 1e12;
    ``grid_only``: only on the grid, their finer look keeps its factors)."""
    import dataclasses

    from nh_operators.solving import CallKind, load

    for name in nh.available_pretrained():
        cal = load(name).calibration
        never = np.full(len(cal.probabilities), 1e-12)
        factors = dict(cal.factors)
        if name in failing:
            for key in list(factors):
                if key[1] is not CallKind.FINE:
                    factors[key] = np.full(len(factors[key]), 1e12)
                elif not grid_only:
                    del factors[key]
        use_calibration(monkeypatch, name, dataclasses.replace(
            cal, estimate_quantiles=never, factors=factors,
            families={fam: dict(f, estimate_quantiles=never)
                      for fam, f in cal.families.items()},
            neural_seconds=costs.get(name, 1e3), neural_seconds_batched=costs.get(name, 1e3)))
