"""Tests of the classical solvers: exact solutions, fitted orders, references, baselines."""

import re
import warnings

import numpy as np
import pytest
from solver_helpers import dop853, fitted_order, l_tot, max_error

from nh_operators import (
    PHYSICAL_POTENTIALS,
    SENSORS,
    TIMES,
    V0,
    BoundedPotential,
    BoundedPotentialSpace,
)
from nh_operators.solvers import (
    METHODS,
    ORDERS,
    integrate,
    integrate_sensors,
    paper_rk4,
    reference_solve,
)

SHO = PHYSICAL_POTENTIALS["sho"]
MFF = PHYSICAL_POTENTIALS["mff"]
MORSE = PHYSICAL_POTENTIALS["morse"]
DOUBLE_WELL = PHYSICAL_POTENTIALS["double_well"]
SYMPLECTIC = ["verlet", "yoshida4", "yoshida6", "yoshida8"]



# ------------------------------------------------------------------- the registry


def test_methods_and_orders_registry():
    assert set(METHODS) == set(ORDERS) == {"rk4", "verlet", "yoshida4", "yoshida6", "yoshida8"}
    assert METHODS["rk4"] is None
    for name in SYMPLECTIC:
        w = METHODS[name]
        # a consistent, symmetric composition of Verlet steps (symmetric: even order)
        assert np.sum(w) == pytest.approx(1.0, abs=1e-14)
        np.testing.assert_allclose(w, w[::-1], rtol=0, atol=1e-15)
    assert [len(METHODS[n]) for n in SYMPLECTIC] == [1, 3, 9, 27]
    # Yoshida's order conditions for the triple jump w1, w0, w1: 2 w1 + w0 = 1 and
    # 2 w1^(k+1) + w0^(k+1) = 0 when raising an order-k method to order k + 2
    for name, k in (("yoshida4", 2), ("yoshida6", 4), ("yoshida8", 6)):
        w = METHODS[name]
        inner = METHODS["verlet" if k == 2 else f"yoshida{k}"]
        w1 = w[: len(inner)].sum()
        w0 = w[len(inner) : 2 * len(inner)].sum()
        assert 2 * w1 + w0 == pytest.approx(1.0, abs=1e-14)
        assert 2 * w1 ** (k + 1) + w0 ** (k + 1) == pytest.approx(0.0, abs=1e-13)


# ----------------------------------------------------------- exact solutions


@pytest.mark.parametrize("method", list(METHODS))
def test_sho_converges_to_exact_solution(method):
    q_exact, p_exact = SHO.exact(TIMES)
    errors = [max_error(*integrate(SHO, TIMES, method, s), q_exact, p_exact) for s in (1, 2, 4)]
    assert errors[0] > errors[1] > errors[2]
    q, p = integrate(SHO, TIMES, method, 16)
    tolerance = 1e-4 if method == "verlet" else 1e-8
    assert max_error(q, p, q_exact, p_exact) < tolerance


ORDER_SUBSTEPS = {
    # substep ranges in the asymptotic regime, errors well above the ~1e-13 floor
    ("sho", "rk4"): (1, 2, 4, 8, 16),
    ("sho", "verlet"): (1, 2, 4, 8, 16, 32),
    ("sho", "yoshida4"): (2, 4, 8, 16, 32),
    ("sho", "yoshida6"): (2, 4, 8, 16),
    ("sho", "yoshida8"): (2, 4, 8, 16),
    ("morse", "rk4"): (32, 64, 128, 256),
    ("morse", "verlet"): (8, 16, 32, 64, 128),
    ("morse", "yoshida4"): (8, 16, 32, 64, 128),
    ("morse", "yoshida6"): (4, 8, 16, 32),
    ("morse", "yoshida8"): (4, 8, 16),
}


@pytest.fixture(scope="module")
def morse_reference():
    t = np.linspace(0.0, 2.0, 11)
    # scipy caps rtol at 100 eps; the solution is good to a few 1e-13
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return dop853(lambda q: -MORSE.dV(q), t, rtol=1e-14, atol=1e-14)


@pytest.mark.filterwarnings("ignore::nh_operators.solvers.ResolutionWarning")  # coarse on purpose
@pytest.mark.parametrize(("name", "method"), list(ORDER_SUBSTEPS))
def test_fitted_convergence_order(name, method, morse_reference):
    t = np.linspace(0.0, 2.0, 11)  # output interval 0.2, h = 0.2 / substeps
    if name == "sho":
        pot = SHO
        q_ref, p_ref = SHO.exact(t)
    else:
        pot = MORSE
        q_ref, p_ref = morse_reference
    substeps = ORDER_SUBSTEPS[name, method]
    errors = np.array([max_error(*integrate(pot, t, method, s), q_ref, p_ref) for s in substeps])
    assert errors.min() > 1e-11  # far above the reference's error: the fit measures the method
    assert fitted_order(substeps, errors) == pytest.approx(ORDERS[method], abs=0.3)


@pytest.mark.filterwarnings("ignore::nh_operators.solvers.ResolutionWarning")  # coarse on purpose
@pytest.mark.parametrize("method", list(METHODS))
def test_mff_converges_slowly_across_the_kink(method):
    # the force jumps from +4 to -4 at q = 1/2: fixed steps are first order there
    q_exact, p_exact = MFF.exact(TIMES)
    substeps = (8, 16, 32, 64)
    errors = np.array([max_error(*integrate(MFF, TIMES, method, s), q_exact, p_exact)
                       for s in substeps])
    assert np.all(np.diff(errors) < 0)
    assert errors[-1] < 2e-2
    assert 0.7 < fitted_order(substeps, errors) < 1.5


# --------------------------------------------------------------------- energy


@pytest.mark.parametrize("pot", [DOUBLE_WELL, MORSE], ids=["double_well", "morse"])
@pytest.mark.parametrize(("method", "substeps"),
                         [("verlet", 4), ("yoshida4", 2), ("yoshida6", 1), ("yoshida8", 1)])
def test_symplectic_energy_error_is_bounded(pot, method, substeps):
    t = np.linspace(0.0, 20.0, 991)  # the TIMES spacing, ten times as long
    q, p = integrate(pot, t, method, substeps)
    energy_error = np.abs(0.5 * p**2 + pot.V(q) - V0)
    early = energy_error[t <= 2].max()
    late = energy_error[t >= 18].max()
    assert late <= 1.1 * early  # no drift over ~20 oscillations
    assert early < 5e-3
    assert np.all((q > -0.05) & (q < 1.05))


@pytest.mark.parametrize("pot", [DOUBLE_WELL, MORSE], ids=["double_well", "morse"])
def test_rk4_energy_drifts(pot):
    # the contrast: RK4 is not symplectic and its energy error grows with time
    t = np.linspace(0.0, 20.0, 991)
    q, p = integrate(pot, t, "rk4", 2)
    energy_error = np.abs(0.5 * p**2 + pot.V(q) - V0)
    assert energy_error[t >= 18].max() > 2 * energy_error[t <= 2].max()


# ------------------------------------------------------------------ reference


def _check_reference_against_scipy(pot, q_ref, p_ref):
    q, p = dop853(lambda x: -float(pot.dV(x)), TIMES)
    assert l_tot(q, p, q_ref, p_ref) <= 1e-12
    # the truth's own energy: p²/2 + V(q) = V0 along the trajectory
    assert np.max(np.abs(0.5 * p_ref**2 + pot.V(q_ref) - V0)) <= 1e-10


def test_reference_matches_scipy_dop853(pots, reference):
    q_ref, p_ref, info = reference
    for i in range(3):
        _check_reference_against_scipy(pots[i], q_ref[i], p_ref[i])
    assert info["energy_error"].shape == (len(pots),)
    assert np.all(info["energy_error"] <= 1e-10)
    assert np.all(info["steps"] > 0)


@pytest.mark.slow
def test_reference_matches_scipy_dop853_many():
    pots = BoundedPotentialSpace.potentials(BoundedPotentialSpace(seed=42).random(200))
    q_ref, p_ref, info = reference_solve(pots, TIMES, full_output=True)
    assert np.all(info["energy_error"] <= 1e-10) and np.all(info["steps"] > 0)
    for i in range(len(pots)):
        _check_reference_against_scipy(pots[i], q_ref[i], p_ref[i])


def test_reference_batch_equals_single_calls(pots, reference):
    q_ref, p_ref, info = reference
    for i in (0, 5):
        q, p, single = reference_solve(pots[i], TIMES, full_output=True)
        assert q.shape == p.shape == (TIMES.size,)
        np.testing.assert_array_equal(q, q_ref[i])
        np.testing.assert_array_equal(p, p_ref[i])
        assert single["energy_error"] == info["energy_error"][i]
        assert single["steps"] == info["steps"][i]


def test_reference_on_analytic_potentials():
    q, p = reference_solve(SHO, TIMES)
    q_exact, p_exact = SHO.exact(TIMES)
    assert max_error(q, p, q_exact, p_exact) < 1e-10
    q, p, info = reference_solve(DOUBLE_WELL, TIMES[::-1], full_output=True)
    assert q.shape == (TIMES.size,)
    assert info["energy_error"] < 1e-10
    q_sorted, p_sorted = reference_solve(DOUBLE_WELL, TIMES)
    np.testing.assert_allclose(q[::-1], q_sorted, rtol=0, atol=1e-14)
    np.testing.assert_allclose(p[::-1], p_sorted, rtol=0, atol=1e-14)


# ------------------------------------------------- integrate on exact potentials


def test_integrate_converges_to_reference_on_bspline_potentials(pots, reference):
    q_ref, p_ref, _ = reference
    q, p = integrate(pots, TIMES, "rk4", 64)
    assert np.all(l_tot(q, p, q_ref, p_ref) <= 1e-12)
    for method in METHODS:
        coarse = l_tot(*integrate(pots, TIMES, method, 4), q_ref, p_ref)
        fine = l_tot(*integrate(pots, TIMES, method, 64), q_ref, p_ref)
        # at least second order on these C² potentials: 16x smaller h, 256x smaller L
        assert np.all(fine < coarse / 200), method


@pytest.mark.parametrize("method", list(METHODS))
def test_batch_equals_stacked_single_calls(pots, method):
    t = np.random.default_rng(1).uniform(0, 2, 30)
    q, p = integrate(pots, t, method, 3)
    assert q.shape == p.shape == (len(pots), 30)
    for i in range(len(pots)):
        qi, pi = integrate(pots[i], t, method, 3)
        assert qi.shape == pi.shape == (30,)
        np.testing.assert_array_equal(qi, q[i])
        np.testing.assert_array_equal(pi, p[i])


def test_list_of_analytic_potentials_is_stacked():
    pots = [SHO, DOUBLE_WELL, MORSE]
    q, p = integrate(pots, TIMES, "yoshida4", 2)
    assert q.shape == p.shape == (3, TIMES.size)
    for i, pot in enumerate(pots):
        qi, pi = integrate(pot, TIMES, "yoshida4", 2)
        np.testing.assert_array_equal(q[i], qi)
        np.testing.assert_array_equal(p[i], pi)


def test_compiled_and_python_paths_agree(pots):
    # the same stepper, once compiled on the B-spline, once in Python on its dV
    pot = pots[2]
    q_fast, p_fast = integrate(pot, TIMES, "yoshida4", 2)
    q_slow, p_slow = integrate(_DVOnly(pot), TIMES, "yoshida4", 2)
    np.testing.assert_allclose(q_fast, q_slow, rtol=0, atol=1e-12)
    np.testing.assert_allclose(p_fast, p_slow, rtol=0, atol=1e-12)


class _DVOnly:
    def __init__(self, pot):
        self.pot = pot

    def dV(self, q):
        return self.pot.dV(q)


# ------------------------------------------------------------------ query times


@pytest.mark.parametrize("method", ["rk4", "yoshida6"])
def test_query_order_does_not_matter(pots, method):
    rng = np.random.default_rng(3)
    perm = rng.permutation(TIMES.size)
    q, p = integrate(pots, TIMES[perm], method, 2)
    q_sorted, p_sorted = integrate(pots, TIMES, method, 2)
    np.testing.assert_array_equal(q, q_sorted[:, perm])
    np.testing.assert_array_equal(p, p_sorted[:, perm])
    # non-grid times, shuffled and with repeats
    t = rng.uniform(0, 2, 25)
    t = np.concatenate([t, t[:5]])
    q, p = integrate(SHO, t, method, 2)
    order = np.argsort(t)
    q_s, p_s = integrate(SHO, t[order], method, 2)
    np.testing.assert_array_equal(q[order], q_s)
    np.testing.assert_array_equal(p[order], p_s)
    np.testing.assert_array_equal(q[-5:], q[:5])


def test_column_times_and_zero_time():
    q, p = integrate(SHO, TIMES[:, None], "rk4", 2)
    q1, p1 = integrate(SHO, TIMES, "rk4", 2)
    np.testing.assert_array_equal(q, q1)
    np.testing.assert_array_equal(p, p1)
    q, p = integrate(SHO, [0.0], "rk4", 1)
    np.testing.assert_array_equal(q, [0.0])
    np.testing.assert_array_equal(p, [0.0])
    q, p = integrate(SHO, [0.7, 0.0, 0.0], "verlet", 1)
    assert q[1] == q[2] == p[1] == p[2] == 0.0


@pytest.mark.parametrize("method", ["rk4", "yoshida6", "yoshida8"])
def test_hermite_interpolation_is_fourth_order(method):
    # non-grid query times: values between step ends come from cubic Hermite
    # interpolation, O(h^4) even when the method itself is more accurate
    t = np.random.default_rng(5).uniform(0.01, 2.0, 40)
    q_exact, p_exact = SHO.exact(t)
    substeps = (1, 2, 4, 8)
    errors = [max_error(*integrate(SHO, t, method, s), q_exact, p_exact) for s in substeps]
    assert min(errors) > 1e-12
    assert fitted_order(substeps, errors) == pytest.approx(4.0, abs=0.3)


@pytest.mark.filterwarnings("ignore::nh_operators.solvers.ResolutionWarning")  # coarse on purpose
def test_interval_sets_the_step():
    t = np.array([0.3, 1.1])
    q_exact, p_exact = SHO.exact(t)
    coarse = max_error(*integrate(SHO, t, "yoshida4", 1, interval=0.4), q_exact, p_exact)
    fine = max_error(*integrate(SHO, t, "yoshida4", 1, interval=0.05), q_exact, p_exact)
    # 8x smaller steps, fourth order: ~4000x smaller error
    assert fine < coarse / 1000
    # the same step through substeps
    q1, p1 = integrate(SHO, t, "yoshida4", 8, interval=0.4)
    q2, p2 = integrate(SHO, t, "yoshida4", 1, interval=0.05)
    np.testing.assert_allclose(q1, q2, rtol=0, atol=1e-15)
    np.testing.assert_allclose(p1, p2, rtol=0, atol=1e-14)


# ---------------------------------------------------------------------- errors


def test_bad_method():
    with pytest.raises(ValueError, match=re.escape("unknown method 'rk5'; choose one of")):
        integrate(SHO, TIMES, "rk5")
    with pytest.raises(ValueError, match="unknown method 'euler'"):
        integrate_sensors(8.0 * (SENSORS - 0.5) ** 2, TIMES, "euler")


@pytest.mark.parametrize("substeps", [0, -2, 2.5, float("nan")])
def test_bad_substeps(pots, substeps):
    message = f"substeps must be a positive integer, got {substeps}"
    with pytest.raises(ValueError, match=re.escape(message)):
        integrate(pots, TIMES, "rk4", substeps)
    with pytest.raises(ValueError, match=re.escape(message)):
        integrate(SHO, TIMES, "rk4", substeps)
    with pytest.raises(ValueError, match=re.escape(message)):
        integrate_sensors(8.0 * (SENSORS - 0.5) ** 2, TIMES, "rk4", substeps)


@pytest.mark.parametrize("bad", [[0.0, -0.1, 1.0], [0.0, np.nan], [np.inf]])
def test_bad_times(pots, bad):
    message = "t must hold finite times ≥ 0"
    for call in (lambda: integrate(pots, bad), lambda: integrate(SHO, bad),
                 lambda: integrate_sensors(8.0 * (SENSORS - 0.5) ** 2, bad),
                 lambda: reference_solve(pots, bad), lambda: paper_rk4(pots.V(SENSORS), bad)):
        with pytest.raises(ValueError, match=re.escape(message)):
            call()


@pytest.mark.parametrize("bad", [[], np.zeros((3, 2)), 1.0])
def test_bad_time_shapes(bad):
    with pytest.raises(ValueError, match="t must be a non-empty 1-D array of times"):
        integrate(SHO, bad)


def test_bad_interval():
    with pytest.raises(ValueError, match=re.escape("interval must be positive, got 0")):
        integrate(SHO, [0.5], interval=0)
    with pytest.raises(ValueError, match="interval must be positive"):
        integrate(SHO, [0.5], interval=-0.1)


def test_potential_without_dV():
    with pytest.raises(TypeError, match="dV"):
        integrate(np.zeros(100), TIMES)
    with pytest.raises(TypeError, match="dV"):
        reference_solve(object(), TIMES)


def test_bounded_potential_single_shapes():
    pot = BoundedPotential([0, 0.3, 0.7, 1], [2, -2, 1, 2])
    for solve in (lambda t: integrate(pot, t, "rk4", 2), lambda t: reference_solve(pot, t)):
        q, p = solve(TIMES)
        assert q.shape == p.shape == (TIMES.size,)
        assert q.dtype == p.dtype == np.float64
        assert np.all((q >= -1e-9) & (q <= 1 + 1e-9))
