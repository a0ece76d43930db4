"""Errors about one row carry the row as a number: solvers raise them, callers renumber them."""

import math
import pickle

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.solvers import PeriodError
from nh_operators.solvers.row_error import RowError, about_row
from nh_operators.solvers.rows import row_source
from nh_operators.solvers.states import check_states
from nh_operators.solving import many

DW = nh.PHYSICAL_POTENTIALS["double_well"]


def test_row_error_names_its_row_and_renumbers_to_the_same_class():
    err = RowError("its energy exceeds V0", row=3)
    assert (err.row, err.message, str(err)) == (3, "its energy exceeds V0",
                                                "row 3: its energy exceeds V0")
    moved = err.renumbered(40)
    assert type(moved) is RowError and str(moved) == "row 40: its energy exceeds V0"
    assert err.row == 3  # unchanged
    single = PeriodError("T is too loose")
    assert single.row is None and str(single) == "T is too loose"
    period = single.renumbered(7)
    assert type(period) is PeriodError and issubclass(PeriodError, ValueError)
    assert (period.row, str(period)) == (7, "row 7: T is too loose")
    with pytest.raises(TypeError):
        RowError(3, "the row must be a keyword")  # type: ignore[arg-type]


def test_about_row_keeps_a_row_errors_class_and_wraps_a_plain_value_error():
    wrapped = about_row(ValueError("t must be finite"), 5)
    assert type(wrapped) is RowError and str(wrapped) == "row 5: t must be finite"
    kept = about_row(PeriodError("no period", row=0), 9)
    assert type(kept) is PeriodError and (kept.row, str(kept)) == (9, "row 9: no period")


def test_row_errors_survive_pickling_with_their_row():
    for err in (RowError("bad state", row=2), PeriodError("no period"),
                PeriodError("no period", row=11)):
        back = pickle.loads(pickle.dumps(err))
        assert (type(back), back.row, back.message, str(back)) == (
            type(err), err.row, err.message, str(err))


def test_check_states_raises_the_row_it_found():
    value_at = row_source("sho", "exact V").values_at
    with pytest.raises(RowError) as err:
        check_states(np.array([0.5, 0.5, 1.5]), np.zeros(3), value_at, batched=True)
    assert err.value.row == 2
    assert str(err.value) == "row 2: q0 = 1.5 is outside [0, 1], where V is defined"
    with pytest.raises(RowError) as err:
        check_states(np.array([1.5]), np.zeros(1), value_at)
    assert err.value.row is None and str(err.value).startswith("q0 = 1.5 is outside")


def _separatrix_rows(n_before):
    """``n_before`` rows at rest on the sensors' double well, then one released from
    q = 0.2 with exactly the energy of the spline's barrier top (no period)."""
    V = DW.V(nh.SENSORS)
    spline = row_source(V[None], "sensors")
    top, bottom = spline.values_at(np.array([0.5, 0.2]))
    rows = np.repeat(V[None], n_before + 1, axis=0)
    q0 = np.r_[np.zeros(n_before), 0.2]
    p0 = np.r_[np.zeros(n_before), math.sqrt(2 * (top - bottom))]
    return rows, q0, p0


def test_a_period_error_in_a_later_chunk_names_the_row_of_the_call(monkeypatch):
    monkeypatch.setattr(many, "CHUNK", 4)  # row 9 is row 1 of the third chunk
    V, q0, p0 = _separatrix_rows(9)
    with pytest.raises(PeriodError, match=r"^row 9: the period of the orbit from \(q0 = 0.2, "
                       r"p0 = 1.125\), energy 0.6328124492, cannot be found") as err:
        nh.solve_many(V, [1e3], tol=1e-8, q0=q0, p0=p0, method="classical")
    assert err.value.row == 9


def test_one_by_one_rows_name_their_row_and_keep_the_period_error():
    with pytest.raises(PeriodError, match=r"^row 1: the period of the orbit") as err:
        nh.solve_many([DW, DW], [1e3], tol=1e-8, q0=[0.2, 0.2],
                      p0=[0.1, math.sqrt(2 * (float(DW.V(0.5)) - float(DW.V(0.2))))],
                      method="classical")
    assert err.value.row == 1
