"""RK4 in the curve parameter λ on B-spline potentials (solve's classical path for them):
lockstep rows bit for bit the one-row kernel, fourth order against the independent
reference, and the same limit as RK4 in q."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.potentials import BoundedPotentialSpace
from nh_operators.solvers import _curve_fixed

TQ = nh.TIMES


@pytest.fixture(scope="module")
def pots():
    space = BoundedPotentialSpace(seed=3)
    return space.potentials(space.random(11))


def states(pots, seed):
    """Random bounded states well inside each potential's well."""
    rng = np.random.default_rng(seed)
    n = pots.params.shape[0]
    q0 = rng.uniform(0.2, 0.8, n)
    room = 2.0 - np.array([pots[i].V(np.array([q0[i]]))[0] for i in range(n)])
    p0 = rng.choice([-1.0, 1.0], n) * np.sqrt(2 * room * rng.uniform(0.0, 0.8, n))
    return q0, p0


def run(pots, rows, tq, hs, nsteps, q0s, p0s):
    oq = np.empty((rows.size, tq.shape[-1]))
    op = np.empty_like(oq)
    _curve_fixed.curve_rows_fixed(pots.params, rows, tq, hs, nsteps, oq, op, q0s, p0s)
    return oq, op


def one_by_one(pots, rows, tq, hs, nsteps, q0s, p0s):
    oq = np.empty((rows.size, tq.shape[-1]))
    op = np.empty_like(oq)
    for k, i in enumerate(rows):
        grid = (tq, hs, nsteps) if tq.ndim == 1 else (tq[i], hs[i], nsteps[i])
        _curve_fixed._curve_row.py_func(pots.params[i], *grid, oq[k], op[k], q0s[i], p0s[i])
    return oq, op


@pytest.mark.parametrize("n", [1, 4, 7, 11])  # below, at and past a multiple of LANES
def test_lockstep_rows_equal_the_uncompiled_one_row_kernel(pots, n):
    q0s, p0s = states(pots, n)
    rows = np.arange(n)
    tq = np.sort(np.r_[0.0, np.random.default_rng(n).uniform(0, 1.5, 20)])
    got = run(pots, rows, tq, 1.5 / 45, 45, q0s, p0s)
    ref = one_by_one(pots, rows, tq, 1.5 / 45, 45, q0s, p0s)
    np.testing.assert_array_equal(got[0], ref[0])
    np.testing.assert_array_equal(got[1], ref[1])
    assert got[0][:, 0].tolist() == q0s[:n].tolist()  # t = 0 is the starting state


def test_own_grids_and_a_subset_of_rows(pots):
    n = pots.params.shape[0]
    q0s, p0s = states(pots, 5)
    rng = np.random.default_rng(5)
    tq = np.sort(rng.uniform(0, 2, (n, 9)), axis=1)
    nsteps = rng.integers(20, 60, n)
    hs = tq[:, -1] / nsteps
    rows = np.array([10, 2, 3, 7, 0, 5])
    got = run(pots, rows, tq, hs, nsteps, q0s, p0s)
    ref = one_by_one(pots, rows, tq, hs, nsteps, q0s, p0s)
    np.testing.assert_array_equal(got[0], ref[0])
    np.testing.assert_array_equal(got[1], ref[1])


def l_tot(q, p, ref):
    """Per-row L_tot against ``ref`` = (q, p) of :func:`~nh_operators.reference_solve`."""
    return 0.5 * (((q - ref[0]) ** 2).mean(axis=1) + ((p - ref[1]) ** 2).mean(axis=1))


@pytest.mark.parametrize("start", ["rest", "states"])
def test_fourth_order_wherever_rk4_in_q_shows_it(pots, start):
    """Against the independent reference: at every step the worst row's error is within
    2× of RK4 in q, and rows where RK4 in q converges at a clean fourth order (a piece
    boundary or a slow passage near a barrier spoils it on others) converge at fourth
    order in λ too."""
    n = pots.params.shape[0]
    q0s, p0s = (np.zeros(n), np.zeros(n)) if start == "rest" else states(pots, 7)
    ref = nh.reference_solve(pots, TQ, q0=q0s, p0=p0s)
    curve, in_q = [], []
    for sub in (4, 8, 16, 32):
        q, p = run(pots, np.arange(n), TQ, 2.0 / (99 * sub), 99 * sub, q0s, p0s)
        curve.append(np.sqrt(l_tot(q, p, ref)))
        q, p = nh.integrate(pots, TQ, substeps=sub, q0=q0s, p0=p0s, check_resolution=False)
        in_q.append(np.sqrt(l_tot(q, p, ref)))
    curve, in_q = np.array(curve), np.array(in_q)
    ratio = curve.max(axis=1) / in_q.max(axis=1)
    assert np.all((ratio > 0.5) & (ratio < 2.0)), ratio
    clean = np.all(np.abs(np.log2(in_q[:-1] / in_q[1:]) - 4.0) < 0.25, axis=0)
    assert clean.sum() >= 2, clean
    orders = np.log2(curve[:-1, clean] / curve[1:, clean])
    assert np.all(np.abs(orders - 4.0) < 0.4), orders


def test_same_limit_as_rk4_in_q(pots):
    """Both schemes converge to the reference; at 64 substeps both are within 1e-12."""
    n = pots.params.shape[0]
    q0s, p0s = states(pots, 9)
    ref = nh.reference_solve(pots, TQ, q0=q0s, p0=p0s)
    q, p = run(pots, np.arange(n), TQ, 2.0 / (99 * 64), 99 * 64, q0s, p0s)
    assert l_tot(q, p, ref).max() < 1e-12
    q, p = nh.integrate(pots, TQ, substeps=64, q0=q0s, p0=p0s, check_resolution=False)
    assert l_tot(q, p, ref).max() < 1e-12


def test_solve_on_a_bspline_meets_tol_with_the_curve_kernel(pots):
    """solve_many of B-spline rows goes through the curve kernel, and each row equals a
    solve of that row alone; every answer meets tol against the reference."""
    n = pots.params.shape[0]
    q0s, p0s = states(pots, 11)
    ref = nh.reference_solve(pots, TQ, q0=q0s, p0=p0s)
    for tol in (1e-4, 1e-10):
        many = nh.solve_many(pots, TQ, q0=q0s, p0=p0s, tol=tol, method="classical",
                             progress=False)
        assert np.all(l_tot(many.q, many.p, ref) <= tol)
        one = nh.solve(pots[3], TQ, q0=q0s[3], p0=p0s[3], tol=tol, method="classical")
        np.testing.assert_array_equal(one.q, many.q[3])
        sub = int(many.substeps[3])
        direct = run(pots, np.array([3]), TQ, 2.0 / (99 * sub), 99 * sub, q0s, p0s)
        np.testing.assert_array_equal(direct[0][0], many.q[3])
