"""The typed results of the row path: HorizonPlan, PeriodShift and RowSolution (issue 40)."""

import dataclasses
import math

import numpy as np
import pytest

import nh_operators.solvers as solvers
from nh_operators.solvers.periodic import (HorizonPlan, PeriodError, PeriodShift, phase_error,
                                           plan_horizon)
from nh_operators.solvers.rows import (RowSolution, _check_return, _Levels, row_source,
                                       solve_rows)

ZERO = np.array([0.0])
TOL = np.array([1e-8])


def sho_plan(times):
    """The plan of the SHO released at rest from q = 0 (period π/2) at sorted ``times``."""
    return plan_horizon(row_source("sho", "exact V"), np.array([times]), ZERO, ZERO, TOL)


def test_a_short_horizon_plans_the_asked_times_without_a_period():
    plan = sho_plan([0.5, 1.0])
    assert isinstance(plan, HorizonPlan) and solvers.HorizonPlan is HorizonPlan
    assert plan.column is None and plan.shifts is None
    np.testing.assert_array_equal(plan.work, [[0.5, 1.0]])
    assert plan.periodic.tolist() == [False] and np.isnan(plan.period[0])
    assert plan.phase.tolist() == [0.0]


def test_a_far_horizon_is_reduced_into_one_period_with_its_shifts():
    plan = sho_plan([0.5, 10.0])
    T = plan.period[0]
    assert abs(T - math.pi / 2) <= 1e-12 and plan.periodic.tolist() == [True]
    # 10 = 6 T + r: the working times are 0.5, r and T, sorted; T's column is the last
    assert plan.column is not None and plan.column.tolist() == [[0, 1, 2]]
    np.testing.assert_array_equal(plan.work, [[0.5, 10.0 - 6 * T, T]])
    shifts = plan.shifts
    assert isinstance(shifts, PeriodShift) and solvers.PeriodShift is PeriodShift
    assert shifts.rows.tolist() == [0] and shifts.horizon.tolist() == [10.0]
    assert 0 < shifts.period_error[0] <= 1e-12
    # no turn before 0.5: the rounding of t only; six turns by 10: 6 δT + ulp(10)
    assert shifts.shift[0, 0] == np.spacing(0.5)
    assert shifts.shift[0, 1] == 6 * shifts.period_error[0] + np.spacing(10.0)


def test_phase_error_without_shifts_is_the_plans_phase_and_with_them_measured():
    src = row_source("sho", "exact V")
    short = sho_plan([0.5, 1.0])
    q = np.array([[0.7, 0.8]])
    assert phase_error(src, short, q, q, TOL) is short.phase
    sol = solve_rows(src, np.array([10.0, 0.5]), ZERO, ZERO, TOL)
    plan = sho_plan([0.5, 10.0])
    # the states in the plan's sorted order (0.5, then 10)
    phase = phase_error(src, plan, sol.q[:, ::-1], sol.p[:, ::-1], TOL)
    np.testing.assert_array_equal(phase, sol.phase)
    assert 0 < phase[0] < 1e-20


def test_phase_error_names_the_period_its_error_and_the_horizon():
    src = row_source("sho", "exact V")
    sol = solve_rows(src, np.array([10.0, 0.5]), ZERO, ZERO, TOL)
    plan = sho_plan([0.5, 10.0])
    assert plan.shifts is not None
    loose = dataclasses.replace(plan, shifts=dataclasses.replace(
        plan.shifts, shift=plan.shifts.shift * 1e8,
        period_error=plan.shifts.period_error * 1e8))
    with pytest.raises(PeriodError) as err:
        phase_error(src, loose, sol.q[:, ::-1], sol.p[:, ::-1], TOL, batched=True)
    assert err.value.row == 0
    assert str(err.value).startswith(
        f"row 0: the period T = {plan.period[0]:.15g} is known to "
        f"±{plan.shifts.period_error[0] * 1e8:.2g}; by t = 10 that shifts the phase by up "
        f"to {plan.shifts.shift[0, 1] * 1e8:.2g}, L_tot ")
    assert ", more than a quarter of tol 1e-08 (T is hard to pin down" in str(err.value)


def test_a_missed_return_names_the_period_of_the_plan():
    plan = sho_plan([0.5, 10.0])
    levels = _Levels(np.array([[0.5, 0.6, 0.1]]), np.zeros((1, 3)), np.array([4]), ZERO, [])
    with pytest.raises(PeriodError) as err:
        _check_return(plan, np.array([True]), levels, ZERO, ZERO, TOL, True)
    assert err.value.row == 0
    assert str(err.value) == (
        f"row 0: the orbit does not return to its starting state after the period T = "
        f"{plan.period[0]:.10g} found by quadrature (squared miss 0.005): V has a feature "
        "the turning-point search stepped over")


def test_solve_rows_returns_a_frozen_row_solution():
    src = row_source("sho", "exact V")
    one = solve_rows(src, np.array([10.0, 0.5]), ZERO, ZERO, TOL)
    assert isinstance(one, RowSolution) and solvers.RowSolution is RowSolution
    assert one.q.shape == one.p.shape == (1, 2)
    assert one.substeps.tolist() == [int(one.history[-1][0])]
    # the accepted level's estimate plus the phase part, as root-sum
    assert one.estimate[0] == (math.sqrt(one.history[-1][1]) + math.sqrt(one.phase[0])) ** 2
    assert abs(one.period[0] - math.pi / 2) <= 1e-12
    with pytest.raises(dataclasses.FrozenInstanceError):
        one.q = one.p  # type: ignore[misc]
    both = solve_rows(src, np.array([0.5]), np.array([0.0, 0.1]), ZERO.repeat(2),
                      TOL.repeat(2), batched=True)
    assert both.history == [] and np.isnan(both.period).all()
    assert both.phase.tolist() == [0.0, 0.0]
