"""solve_many's auto decides on measured costs (issue 41): a pilot first measures the
classical solve on the call's own rows, and a network goes on only where what it
accepted there pays for what it cost there."""

import numpy as np
import pytest
from test_many import _calibrations, _dear_classical

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample


@pytest.fixture(scope="module")
def rows():
    """40 Algorithm-1 potentials as sensor values."""
    return np.asarray(nh.generate_dataset(40, seed=41, progress=False).V)


@pytest.fixture()
def small_pilot(monkeypatch):
    """A pilot of 8 rows (2 classical probe rows), so 40 rows get one."""
    from nh_operators.solving import many

    monkeypatch.setattr(many, "PILOT", 8)


def _same_as_classical(sol, V, tol):
    ref = nh.solve_many(V, nh.TIMES, tol=tol, method="classical")
    assert not sol.neural.any() and set(sol.methods) == {"rk4"}
    assert np.array_equal(sol.q, ref.q) and np.array_equal(sol.p, ref.p)
    assert np.array_equal(sol.error_estimate, ref.error_estimate)
    assert np.array_equal(sol.substeps, ref.substeps)
    assert sol.converged.all()


def test_networks_that_cannot_beat_the_measured_classical_cost_are_not_run(
        monkeypatch, rows, small_pilot):
    """Classical measured free: no candidate can pay even accepting every row, so none is
    run (``tried`` is empty), and every row is exactly method='classical''s."""
    _dear_classical(monkeypatch, seconds=1e-12)
    _calibrations(monkeypatch, {"phaseonet-alg1": 1e-9})
    sol = nh.solve_many(rows, nh.TIMES, tol=1e-2)
    assert sol.tried == []
    _same_as_classical(sol, rows, 1e-2)


def test_a_tol_no_network_meets_stops_every_network_at_the_pilot(monkeypatch, rows,
                                                                small_pilot):
    """Every candidate's estimate fails (no network can meet tol): each is tried on the
    pilot rows only, stopped there, and the rows are answered as method='classical'
    answers them, to the bit."""
    _dear_classical(monkeypatch)
    failing = ("phaseonet-alg1", "phaseonet-paper")
    _calibrations(monkeypatch, {"phaseonet-alg1": 1e-9, "phaseonet-paper": 2e-9},
                  failing=failing)
    sol = nh.solve_many(rows, nh.TIMES, tol=1e-2)
    assert sorted(e["method"] for e in sol.tried) == sorted(failing)
    for entry in sol.tried:
        assert entry["rows"] <= 8 and entry["accepted"] == 0
        assert "not worth its cost" in entry["stopped"]
    _same_as_classical(sol, rows, 1e-2)
    # what a network accepted belongs to the call's rows and is not remembered: the next
    # call tries them on its own pilot again, and stops them again
    again = nh.solve_many(rows, nh.TIMES, tol=1e-2)
    assert sorted(e["method"] for e in again.tried) == sorted(failing)
    assert all(e["accepted"] == 0 and "stopped" in e for e in again.tried)
    _same_as_classical(again, rows, 1e-2)


def test_at_a_loose_tol_a_network_that_pays_answers_rows(monkeypatch, rows, small_pilot):
    """Classical measured dear, phaseonet-alg1 with its own estimate: it goes on past the
    pilot and answers most rows, each within tol of the sensors' spline trajectory; the
    probe rows (a quarter of the pilot's) stay classical."""
    _dear_classical(monkeypatch)
    _calibrations(monkeypatch, {"phaseonet-alg1": 1e-9})
    tol = 1e-2
    sol = nh.solve_many(rows, nh.TIMES, tol=tol)
    assert sol.tried[0]["method"] == "phaseonet-alg1" and "stopped" not in sol.tried[0]
    assert sol.neural.sum() >= 30 and (~sol.neural).sum() >= 2
    q_ref, p_ref = nh.integrate_sensors(rows, nh.TIMES, substeps=256,
                                        check_resolution=False)
    assert np.all(loss_per_sample(sol.q, sol.p, q_ref, p_ref)["L_tot"] <= tol)


def test_a_pilot_keeps_nothing_of_the_networks_for_the_next_call(monkeypatch, rows,
                                                                   small_pilot):
    """A part of fewer than MIN_PILOT rows costs its call's fixed part per row (1.1 ms per
    row on 4 rows, 45× the calibration): remembered as the machine's speed, it kept every
    network out of the next calls. What a pilot measures of the networks now stays in
    its call: only classical passes' costs are remembered, and a second call decides as
    the first did."""
    from nh_operators.solving import costs

    _dear_classical(monkeypatch)
    _calibrations(monkeypatch, {"phaseonet-alg1": 1e-9})
    first = nh.solve_many(rows, nh.TIMES, tol=1e-2)
    names = {e["method"] for e in first.tried}
    assert names and not any(key[0] == "scale" or key[0] in names
                             for key in costs._MEASURED)
    second = nh.solve_many(rows, nh.TIMES, tol=1e-2)
    assert [(e["method"], e["rows"], "stopped" in e) for e in second.tried] == \
        [(e["method"], e["rows"], "stopped" in e) for e in first.tried]
