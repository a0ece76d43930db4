import warnings

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample, physical_reference
from nh_operators.potentials import as_potential
from nh_operators.solvers import solve_classical, start_coarseness

T = np.array([1.7, 0.05, 0.6, 2.0, 1.1])  # unsorted on purpose


def true_loss(sol, q_ref, p_ref):
    return float(loss_per_sample(sol.q, sol.p, q_ref, p_ref)["L_tot"])


@pytest.mark.parametrize("tol", [1e-6, 1e-8, 1e-10, 1e-12])
def test_sho_meets_the_tolerance_and_the_estimate_is_conservative(tol):
    sol = solve_classical("sho", T, tol=tol)
    err = true_loss(sol, *nh.PHYSICAL_POTENTIALS["sho"].exact(T))
    assert sol.error_estimate <= tol and err <= sol.error_estimate
    assert sol.q.shape == (5,) and sol.information == "exact V" and sol.seconds > 0
    # levels double from a step of at most RESOLVED_STEP (8 substeps of TIMES' spacing,
    # which these times use; coarser by start_coarseness, 0 by default: the first level
    # then has 16); the first difference alone is never accepted
    start = 16 // 2 ** start_coarseness(tol)
    assert [s for s, _ in sol.history] == [start * 2 ** i for i in range(len(sol.history))]
    assert sol.history[0][1] == np.inf and len(sol.history) >= 2


# at 1e-8 the kink's first-order convergence runs out of substeps: the warning is the
# answer's own flag, and the test checks the true error instead
@pytest.mark.filterwarnings("ignore:tolerance .* not reached:RuntimeWarning")
@pytest.mark.parametrize("tol", [1e-6, 1e-8])
def test_kink_order_one_is_still_met(tol):
    sol = solve_classical("mff", T, tol=tol)
    assert true_loss(sol, *nh.PHYSICAL_POTENTIALS["mff"].exact(T)) <= tol


def test_generator_potentials_meet_1e_8(pots, reference):
    q_ref, p_ref, _ = reference
    for i in range(3):
        sol = solve_classical(pots[i], nh.TIMES, tol=1e-8, method="yoshida8")
        assert true_loss(sol, q_ref[i], p_ref[i]) <= 1e-8


def test_callable_without_derivative_and_text_expression():
    morse = nh.PHYSICAL_POTENTIALS["morse"]
    q_ref, p_ref = physical_reference("morse", T)
    sol = solve_classical(morse.V, T, tol=1e-9)  # dV by central differences
    assert true_loss(sol, q_ref, p_ref) <= 1e-9
    text = solve_classical("625/8*(q-0.2)**2*(q-0.8)**2", T, tol=1e-9)
    assert true_loss(text, *physical_reference("double_well", T)) <= 1e-9


def test_sensor_values_solve_the_spline():
    V = nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS)
    sol = solve_classical(V, T, tol=1e-10)
    assert sol.information == "sensors"
    assert true_loss(sol, *nh.PHYSICAL_POTENTIALS["sho"].exact(T)) <= 1e-10  # quadratic: exact


def test_errors_are_named(pots):
    with pytest.raises(ValueError, match="tol must be a positive number"):
        solve_classical("sho", T, tol=0)
    with pytest.raises(ValueError, match="unknown method 'euler'"):
        solve_classical("sho", T, method="euler")
    with pytest.raises(ValueError, match="one potential"):
        solve_classical(pots, T)
    with pytest.raises(TypeError, match="cannot use dict"):
        as_potential({"a": 1})
    with pytest.raises(ValueError, match=r"<lambda>\(0\) = 0, but a bounded"):
        solve_classical(lambda q: 8 * q, T)
    with pytest.raises(ValueError, match="unknown name 'x'"):
        solve_classical("x**2", T)


def test_unreachable_tolerance_warns_and_returns_the_finest():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sol = solve_classical("mff", T, tol=1e-14, max_substeps=64)
    assert sol.substeps == 64 and any("not reached within 64" in str(w.message) for w in caught)
