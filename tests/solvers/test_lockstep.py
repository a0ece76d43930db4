"""The fixed-step kernels advance LANES trajectories in lockstep: bit for bit the same as one
at a time, for every method, any number of rows, shared or per-row grids."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.potentials import BoundedPotentialSpace
from nh_operators.potentials._spline_kernels import grid_force
from nh_operators.solvers import _kernels
from nh_operators.solvers.fixed_step import sensor_spline_params
from nh_operators.solvers.schemes import step_method


@pytest.fixture(scope="module")
def params():
    space = BoundedPotentialSpace(seed=3)
    return sensor_spline_params(space.potentials(space.random(11)).V(nh.SENSORS))


def one_by_one(pars, tq, hs, nsteps, method, q0s, p0s):
    rk4, weights = step_method(method)
    oq, op = np.empty(tq.shape), np.empty(tq.shape)
    for i in range(len(pars)):
        _kernels.trajectory_fixed.py_func(grid_force.py_func, pars[i], tq[i], hs[i],
                                           nsteps[i], rk4, weights, oq[i], op[i], q0s[i],
                                           p0s[i])
    return oq, op


@pytest.mark.parametrize("method", ["rk4", "verlet", "yoshida4"])
@pytest.mark.parametrize("n", [1, 4, 7, 11])  # below, at and past a multiple of LANES
def test_lockstep_rows_equal_the_uncompiled_one_at_a_time_kernel(params, method, n):
    pars = params[:n]
    rng = np.random.default_rng(n)
    q0s, p0s = rng.uniform(0.3, 0.7, n), rng.uniform(-0.2, 0.2, n)
    tq = np.sort(np.r_[0.0, rng.uniform(0, 1.5, 20)])
    nsteps, h = 45, 1.5 / 45
    rk4, weights = step_method(method)
    oq, op = np.empty((n, tq.size)), np.empty((n, tq.size))
    _kernels.batch_fixed(grid_force, pars, tq, h, nsteps, rk4, weights, oq, op, q0s, p0s)
    ref = one_by_one(pars, np.tile(tq, (n, 1)), np.full(n, h), np.full(n, nsteps), method,
                     q0s, p0s)
    np.testing.assert_array_equal(oq, ref[0])
    np.testing.assert_array_equal(op, ref[1])
    assert oq[:, 0].tolist() == q0s.tolist()  # t = 0 is the starting state


def test_rows_with_their_own_grids_and_a_subset_of_rows(params):
    n = len(params)
    rng = np.random.default_rng(5)
    q0s, p0s = rng.uniform(0.3, 0.7, n), np.zeros(n)
    tq = np.sort(rng.uniform(0, 2, (n, 9)), axis=1)
    nsteps = rng.integers(20, 60, n)
    hs = tq[:, -1] / nsteps
    ref = one_by_one(params, tq, hs, nsteps, "rk4", q0s, p0s)
    rows = np.array([10, 2, 3, 7, 0, 5])
    rk4, weights = step_method("rk4")
    for grids in ("own", "shared"):
        if grids == "shared":  # every row on row 0's grid: the lockstep path
            tq, hs, nsteps = np.tile(tq[0], (n, 1)), np.full(n, hs[0]), np.full(n, nsteps[0])
            ref = one_by_one(params, tq, hs, nsteps, "rk4", q0s, p0s)
        oq, op = np.empty((rows.size, tq.shape[1])), np.empty((rows.size, tq.shape[1]))
        _kernels.rows_fixed(grid_force, params, rows, tq, hs, nsteps, rk4, weights, oq, op,
                            q0s, p0s)
        np.testing.assert_array_equal(oq, ref[0][rows])
        np.testing.assert_array_equal(op, ref[1][rows])


def test_level_gap_is_the_weighted_mean_square_gap_of_two_levels():
    rng = np.random.default_rng(5)
    q, p, q2, p2 = rng.normal(size=(4, 6, 9))
    w = rng.uniform(size=(6, 9))
    expected = 0.5 * (((q2 - q) ** 2 + (p2 - p) ** 2) * w).sum(axis=1)
    np.testing.assert_allclose(_kernels.level_gap(q, p, q2, p2, w), expected, rtol=1e-14)
    shared = 0.5 * (((q2 - q) ** 2 + (p2 - p) ** 2) * w[0]).sum(axis=1)
    np.testing.assert_allclose(_kernels.level_gap(q, p, q2, p2, w[:1]), shared, rtol=1e-14)


def test_shared_times_and_the_same_times_per_row_give_identical_solves():
    from nh_operators.solvers.rows import row_source, solve_rows

    space = BoundedPotentialSpace(seed=8)
    src = row_source(space.potentials(space.random(9)).V(nh.SENSORS), "sensors")
    rng = np.random.default_rng(2)
    q0s, p0s = rng.uniform(0.3, 0.7, 9), np.zeros(9)
    t = np.array([1.5, 0.0, 0.7, 2.0, 0.2])  # unsorted: answered in the asked order
    tols = np.full(9, 1e-9)
    shared = solve_rows(src, t, q0s, p0s, tols, batched=True)
    own = solve_rows(src, np.tile(t, (9, 1)), q0s, p0s, tols, batched=True)
    for key in ("q", "p", "substeps", "estimate"):
        np.testing.assert_array_equal(getattr(shared, key), getattr(own, key))
    assert np.all(shared.q[:, 1] == q0s)  # t = 0, asked second
