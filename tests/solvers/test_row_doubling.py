"""A single row's doubling in one compiled call (:mod:`nh_operators.solvers._row_doubling`)
gives bit for bit what the level-by-level Python loop gives: answer, estimate, substeps,
history, warnings and errors."""

import warnings
from pathlib import Path

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.solvers import rows, solve_classical
from nh_operators.solvers._row_doubling import double_one_row
from nh_operators.solvers.classical_solve import coerce_potential

DATA = Path(__file__).parent / "data"


def _both(monkeypatch, src, t, q0, p0, tol, method="rk4", max_substeps=4096):
    """solve_rows of one row, compiled and (ONE_ROW_CAP 0) level by level in Python."""
    args = (src, t, np.array([q0]), np.array([p0]), np.array([tol]), method, max_substeps)
    out, messages, calls = [], [], []

    def counted(*a):
        calls.append(1)
        return double_one_row(*a)

    for cap in (rows.ONE_ROW_CAP, 0):
        with monkeypatch.context() as m, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            m.setattr(rows, "ONE_ROW_CAP", cap)
            m.setattr(rows, "double_one_row", counted)
            out.append(rows.solve_rows(*args))
        messages.append([str(w.message) for w in caught])
    assert len(calls) == 1  # the compiled path, then the Python loop
    assert messages[0] == messages[1]  # the cap's warning, where one is due
    return out


def _same(a, b):
    for name in ("q", "p", "substeps", "estimate", "period", "phase"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.history == b.history and len(a.history) >= 2


def _compiled(name):
    """The compiled row source of a named potential (compiled from its second request)."""
    rows.row_source(*coerce_potential(name))
    src = rows.row_source(*coerce_potential(name))
    assert src.compiled
    return src


def _sensor_rows():
    space = nh.BoundedPotentialSpace(seed=31)
    V = space.potentials(space.random(6)).V(nh.SENSORS)
    stored = [np.load(DATA / f"{name}.npz")["V"] for name in
              ("ood_past_guard", "ood_past_guard_plateau", "ood_power_well_slow_passage")]
    return list(V) + stored


@pytest.mark.parametrize("tol", [1e-3, 1e-6, 1e-9])
def test_sensor_rows_match_the_python_loop_bit_for_bit(monkeypatch, tol):
    t = np.array([1.7, 0.05, 0.6, 2.0, 1.1])
    for V in _sensor_rows():  # generator rows (coarse starts) and three that are not
        src = rows.row_source(V, "sensors")
        _same(*_both(monkeypatch, src, t, 0.0, 0.0, tol))
    src = rows.row_source(_sensor_rows()[0], "sensors")  # from a moving state, on TIMES
    _same(*_both(monkeypatch, src, nh.TIMES, 0.3, -0.4, tol))


@pytest.mark.parametrize("method", ["rk4", "verlet", "yoshida4"])
def test_formulas_and_methods_match_the_python_loop(monkeypatch, method):
    for name in ("sho", "mff", "double_well"):  # MFF is not C²: the kink rule
        src = _compiled(name)
        for tol in (1e-4, 1e-8):
            _same(*_both(monkeypatch, src, nh.TIMES, 0.0, 0.0, tol, method))


def test_the_cap_warns_alike_and_from_the_same_frame(monkeypatch):
    _compiled("mff")
    results = []
    for cap in (rows.ONE_ROW_CAP, 0):
        with monkeypatch.context() as m, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            m.setattr(rows, "ONE_ROW_CAP", cap)
            results.append(solve_classical("mff", nh.TIMES, tol=1e-14, max_substeps=64))
        (w,) = [c for c in caught if issubclass(c.category, RuntimeWarning)]
        assert "not reached within 64 substeps" in str(w.message)
        assert w.filename == __file__  # the user's line, not the package's
        results[-1] = (results[-1], str(w.message))
    (a, ma), (b, mb) = results
    assert ma == mb and a.substeps == b.substeps == 64 and a.error_estimate > 1e-14
    np.testing.assert_array_equal(a.q, b.q)
    assert a.history == b.history


def test_a_level_past_max_steps_is_reported_not_run():
    work = np.array([0.0, 1e7])
    src = _compiled("sho")
    seen = []

    def too_many(substeps):
        seen.append(substeps)
        raise ValueError("too many steps")

    with pytest.raises(ValueError, match="too many steps"):
        double_one_row(src.force, src.params[0], work, 0.02, 1.0, 0.0, 0.0, 1e-6, 256.0,
                       1.0, False, 4096, np.array([0.5, 0.5]), True, np.ones(1), 4, too_many)
    assert seen == [1]  # before level 1 ran
