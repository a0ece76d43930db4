"""Small versions of the four operator problems of benchmarks/problems/: each builds,
trains our networks for a few dozen iterations in DeepXDE's loop on full batches (loss
falls, metric finite), and the references the metric trusts are checked against exact solutions.

The problem definitions live in ``benchmarks/problems/operator_problems.py`` (not the
package's API: they are the benchmark's), put on ``sys.path`` here.
"""

import sys
from pathlib import Path

import numpy as np
import pytest
import torch

pytest.importorskip("deepxde")
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks" / "problems"))

import operator_problems as op  # noqa: E402
from deepxde_problems import build_network, dde, predict  # noqa: E402
from nh_operators.models import KLData  # noqa: E402
from references import cumulative_trapezoid, poisson_fd, stokes_velocity  # noqa: E402

TINY = {
    "antiderivative": dict(n_train=40, n_test=8, m=20, n_points=21, batch_size=10),
    "poisson": dict(n_train=4, n_test=8, m=20, n_points=24, batch_size=4),
    "advection": dict(n_train=4, n_test=4, m=20, n_domain=40, n_edge=8, batch_size=4),
    "stokes": dict(n_train=2, n_test=4, m=11, n_domain=30, n_boundary=16, batch_size=2),
}


def train(problem, name, iterations):
    """(loss at the start, loss at the end, test metric) after ``iterations`` steps."""
    net = build_network(name, problem, seed=0)
    data = KLData(problem.data, 0.05) if name == "varonet" else problem.data
    model = dde.Model(data, net)
    model.compile("adam", lr=3e-3)
    torch.manual_seed(0)  # VaRONet's training noise: the same draws whatever ran before
    history, _ = model.train(iterations=iterations, batch_size=problem.batch_size,
                             display_every=iterations, verbose=0)
    first, last = (float(np.sum(history.loss_train[i])) for i in (0, -1))
    return first, last, problem.metric(predict(model, problem))


@pytest.mark.parametrize("problem,name,iterations", [
    ("antiderivative", "deeponet", 40), ("antiderivative", "fno", 30),
    ("poisson", "deeponet", 40), ("poisson", "traonet", 20),
    ("advection", "deeponet", 30), ("advection", "varonet", 60),
    ("stokes", "deeponet", 20), ("stokes", "mambonet", 10),
])
def test_a_network_trains_on_a_small_problem(problem, name, iterations):
    torch.set_num_threads(1)
    p = op.build_problem(problem, **TINY[problem])
    assert p.physics_informed == (problem != "antiderivative")
    first, last, metric = train(p, name, iterations)
    assert np.isfinite(first) and last < first, (first, last)
    assert np.isfinite(metric) and 0.0 < metric < 10.0


def test_problem_shapes_and_boundary_data():
    p = op.build_problem("stokes", **TINY["stokes"])
    assert (p.n_sensors, p.n_outputs, p.query_dim) == (11, 3, 2)
    assert p.test_v.shape == (4, 11) and p.test_x.shape == (33 * 33, 2)
    assert p.test_u.shape == (4, 33 * 33, 2)
    # lid velocity at the corners is zero, so the reference is a regular flow
    np.testing.assert_allclose(p.test_v[:, [0, -1]], 0.0, atol=1e-7)
    # on the lid the reference's u is the input function
    # on the lid the reference's u is the input function: at x = 0.5, sensor 5 of 11
    lid_middle = np.flatnonzero(np.isclose(p.test_x, [0.5, 1.0]).all(axis=1))
    np.testing.assert_allclose(p.test_u[:, lid_middle[0], 0], p.test_v[:, 5], atol=1e-6)
    assert np.abs(p.test_v[:, 5]).max() > 0.05
    np.testing.assert_array_equal(p.test_u[:, p.test_x[:, 0] == 0.0], 0.0)  # no slip, x = 0
    with pytest.raises(ValueError, match="unknown problem 'heat'"):
        op.build_problem("heat")


def test_antiderivative_reference_is_exact_for_the_interpolant():
    grf = op.GRF(0.2, n_grid=201, seed=3)
    v = grf.random(2)
    u = cumulative_trapezoid(v, grf.x)
    # the derivative of the reference at the midpoints is v there (piecewise linear)
    mid = 0.5 * (grf.x[1:] + grf.x[:-1])
    np.testing.assert_allclose(np.diff(u, axis=1) / np.diff(grf.x),
                               grf.eval_batch(v, mid[:, None]), rtol=1e-5, atol=1e-5)
    with pytest.raises(ValueError, match=r"GRF points must lie in \(0.0, 1.0\)"):
        grf.eval_batch(v, np.array([[1.5]]))


def test_poisson_reference_against_an_exact_solution():
    x = np.linspace(0, 1, 1001)
    f = np.stack([np.pi ** 2 * np.sin(np.pi * x), 12 * x ** 2])
    exact = np.stack([np.sin(np.pi * x), x - x ** 4])  # −u'' = f, u(0) = u(1) = 0
    np.testing.assert_allclose(poisson_fd(f, x), exact, rtol=0, atol=2e-6)


def test_advection_reference_is_periodic_and_shifted():
    space = op.PeriodicGRF(seed=1)
    coef = space.random(3)
    x = np.linspace(0, 1, 7)[:, None]
    np.testing.assert_allclose(space.eval_batch(coef, x), space.eval_batch(coef, x + 1.0),
                               atol=1e-5)
    p = op.build_problem("advection", **TINY["advection"])
    # test points: the 33 x 33 grid (x_j, t_k) = (j, k) / 32, x first; u(x, t) = v(x - t)
    u = p.test_u.reshape(4, 33, 33)
    j, k = np.meshgrid(np.arange(33), np.arange(33), indexing="ij")
    np.testing.assert_allclose(u, u[:, (j - k) % 32, 0], atol=1e-5)
    assert np.abs(u).max() > 0.1


def test_stokes_reference_converges_at_second_order():
    def lid(n):
        x = np.linspace(0, 1, n + 1)
        return (16 * x ** 2 * (1 - x) ** 2 * (1 + x))[None]

    coarse = [stokes_velocity(lid(n), n)[0, ::n // 8, ::n // 8] for n in (8, 16, 32)]
    e1 = np.linalg.norm(coarse[0] - coarse[2])
    e2 = np.linalg.norm(coarse[1] - coarse[2])
    assert 3.0 < e1 / e2 < 6.0  # errors 4x smaller per halving (Richardson: 5 exactly)
    uv = stokes_velocity(lid(16), 16)[0]
    # mass conservation: the flux through any vertical line x = const is zero
    flux = np.trapezoid(uv[8, :, 0], dx=1 / 16)
    assert abs(flux) < 1e-2 * np.abs(uv[..., 0]).max()
    with pytest.raises(ValueError, match=r"g must have shape \(B, 17\)"):
        stokes_velocity(lid(8), 16)
