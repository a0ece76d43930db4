"""Tests of the sensor-information baselines: integrate_sensors and paper_rk4."""

import re

import numpy as np
import pytest
from scipy.interpolate import CubicSpline, PchipInterpolator
from solver_helpers import dop853, l_tot

from nh_operators import PHYSICAL_POTENTIALS, SENSORS, TIMES
from nh_operators.solvers import METHODS, integrate, integrate_sensors, paper_rk4


def test_sensor_solver_is_exact_for_a_quadratic_potential():
    # the not-a-knot cubic spline reproduces the SHO's quadratic exactly, so the sensor
    # solver is the exact-potential solver (stages that overshoot q = 1 at the turning
    # point see the end piece continued)
    V = 8.0 * (SENSORS - 0.5) ** 2
    for method in METHODS:
        q, p = integrate_sensors(V, TIMES, method, 2)
        q_exact_pot, p_exact_pot = integrate(PHYSICAL_POTENTIALS["sho"], TIMES, method, 2)
        np.testing.assert_allclose(q, q_exact_pot, rtol=0, atol=1e-12)
        np.testing.assert_allclose(p, p_exact_pot, rtol=0, atol=1e-11)


def _spline_ode(V, interpolation):
    cls = CubicSpline if interpolation == "cubic" else PchipInterpolator
    force = cls(SENSORS, V).derivative()
    return dop853(lambda x: -float(force(x)), TIMES)


def test_sensor_solver_converges_to_information_floor(pots, reference):
    q_ref, p_ref, _ = reference
    V = pots.V(SENSORS)
    substeps = (1, 4, 16, 64)
    for i in (0, 1):
        # the exact solution of the spline-force problem the sensor solver discretises
        q_spl, p_spl = _spline_ode(V[i], "cubic")
        floor = l_tot(q_spl, p_spl, q_ref[i], p_ref[i])
        to_spline, to_truth = [], []
        for s in substeps:
            q, p = integrate_sensors(V[i], TIMES, "rk4", s)
            to_spline.append(l_tot(q, p, q_spl, p_spl))
            to_truth.append(l_tot(q, p, q_ref[i], p_ref[i]))
        assert to_spline[0] > 1e4 * to_spline[-1]
        assert to_spline[-1] <= 1e-12
        assert to_truth[0] > to_truth[-1]
        # √L is a norm: |√L(truth) - √floor| ≤ √L(spline solution)
        for ls, lt in zip(to_spline, to_truth):
            assert abs(np.sqrt(lt) - np.sqrt(floor)) <= np.sqrt(ls) + 1e-7
    # batches: the same numbers
    q, p = integrate_sensors(V, TIMES, "rk4", 4)
    assert q.shape == p.shape == (len(pots), TIMES.size)
    q0, p0 = integrate_sensors(V[3], TIMES, "rk4", 4)
    np.testing.assert_array_equal(q[3], q0)
    np.testing.assert_array_equal(p[3], p0)


def test_pchip_sensor_solver(pots):
    V = pots.V(SENSORS)[4]
    q_spl, p_spl = _spline_ode(V, "pchip")
    coarse = l_tot(*integrate_sensors(V, TIMES, "rk4", 4, "pchip"), q_spl, p_spl)
    fine = l_tot(*integrate_sensors(V, TIMES, "rk4", 128, "pchip"), q_spl, p_spl)
    assert fine < coarse / 1e3
    assert fine < 1e-9
    # a different force from the cubic spline's
    q_cubic, _ = integrate_sensors(V, TIMES, "rk4", 4, "cubic")
    q_pchip, _ = integrate_sensors(V, TIMES, "rk4", 4, "pchip")
    assert np.max(np.abs(q_cubic - q_pchip)) > 1e-6


def test_paper_rk4_is_one_rk4_step_with_pchip(pots):
    V = pots.V(SENSORS)
    q, p = paper_rk4(V)
    q2, p2 = integrate_sensors(V, TIMES, "rk4", 1, "pchip")
    np.testing.assert_array_equal(q, q2)
    np.testing.assert_array_equal(p, p2)
    t = np.array([1.5, 0.25, 0.5])
    q, p = paper_rk4(V[0], t)
    q2, p2 = integrate_sensors(V[0], t, "rk4", 1, "pchip")
    assert q.shape == (3,)
    np.testing.assert_array_equal(q, q2)
    np.testing.assert_array_equal(p, p2)


def test_bad_sensor_values():
    with pytest.raises(ValueError, match=re.escape("must hold the values at the 100 SENSORS")):
        integrate_sensors(np.full(99, 1.0))
    with pytest.raises(ValueError, match=re.escape("must hold the values at the 100 SENSORS")):
        paper_rk4(np.full((2, 101), 1.0))
    V = 8.0 * (SENSORS - 0.5) ** 2
    V[0] = 1.0
    with pytest.raises(ValueError, match=re.escape("V(0) = 1")):
        integrate_sensors(V)
    with pytest.raises(ValueError, match=re.escape("interpolation must be 'cubic' or 'pchip'")):
        integrate_sensors(8.0 * (SENSORS - 0.5) ** 2, interpolation="linear")


def test_compiled_not_a_knot_spline_equals_scipys_and_ignores_the_batch(pots):
    from nh_operators.solvers import sensor_spline_params
    from nh_operators.solvers.fixed_step import _piece_coefficients

    V = np.vstack([pots.V(SENSORS), 8.0 * (SENSORS - 0.5) ** 2, np.sin(7 * SENSORS) + 1])
    ours = sensor_spline_params(V)
    scipy_c = CubicSpline(SENSORS, V, axis=1, bc_type="not-a-knot").c
    np.testing.assert_allclose(ours, _piece_coefficients(scipy_c), rtol=0, atol=1e-13)
    for i in range(len(V)):  # row by row: the same bits at batch 1 and in a batch
        np.testing.assert_array_equal(sensor_spline_params(V[i:i + 1])[0], ours[i])
    # a cubic is its own not-a-knot spline: a3 per piece = the cubic's s³ coefficient
    cubic = sensor_spline_params((SENSORS**3)[None])[0].reshape(99, 4)
    np.testing.assert_allclose(cubic[:, 3], (1 / 99) ** 3, rtol=1e-9)
