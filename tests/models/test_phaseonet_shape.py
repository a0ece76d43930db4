"""PhaseONet's computed shape (the quadrature start): the phase integral inverted on the
composite rule, against exact and independent trajectories, near a separatrix included;
the compiled rows against the torch formulas; and the options' errors."""

import math

import numpy as np
import pytest
import torch
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline

from nh_operators.models import PhaseONet, StatePhaseONet, cast_network
from nh_operators.models.orbit_shape import harmonic_shape, shape_table
from nh_operators.models.phase_start import HarmonicStart, QuadratureStart, start_shape

X = np.linspace(0, 1, 100)
W = 4.0  # V = 2 − W² q (1 − q) / 2: harmonic about q = 1/2 with frequency W
DOUBLE_WELL = 2 - 40 * X**2 * (1 - X) ** 2 * (0.1 + 8 * (X - 0.5) ** 2)  # barrier at 1/2


def computed(grid=256, seed=0, panels=32):
    torch.manual_seed(seed)
    net = StatePhaseONet(width=16, depth=1, basis=4, grid=grid, shape=QuadratureStart(),
                         panels=panels)
    return cast_network(net, torch.float64).eval()


def rows(V, q0, p0):
    V = np.atleast_2d(V)
    n = len(V)
    return torch.tensor(np.column_stack([V, np.broadcast_to(q0, n), np.broadcast_to(p0, n)]))


def spline_trajectory(V, q0, p0, t):
    """DOP853 at rtol 1e-12 on the same not-a-knot sensor spline: independent of the
    quadrature."""
    spline = CubicSpline(X, V)
    force = spline.derivative()
    sol = solve_ivp(lambda _, y: (y[1], -force(y[0])), (0, t[-1]), (q0, p0), t_eval=t,
                    method="DOP853", rtol=1e-12, atol=1e-13)
    return sol.y


def test_at_construction_the_network_is_the_exact_harmonic_orbit():
    V = 2 - W**2 * X * (1 - X) / 2
    t = np.linspace(0, 5, 61)
    net = computed(grid=2048)
    for q0, p0 in ((0.3, -0.5), (0.45, 0.9), (0.1, 0.0)):
        with torch.no_grad():
            y = net((rows(V, q0, p0), torch.tensor(t)[:, None]))[0].numpy()
        c = q0 - 0.5
        q = 0.5 + c * np.cos(W * t) + p0 / W * np.sin(W * t)
        p = -c * W * np.sin(W * t) + p0 * np.cos(W * t)
        # the shape's table (512 nodes) and the lerp on 2048 nodes of the half-phase
        np.testing.assert_allclose(y[:, 0], q, atol=2e-6)
        np.testing.assert_allclose(y[:, 1], p, atol=2e-5)


@pytest.mark.parametrize("q0, p0, grid, panels, bound", [
    (0.2, 0.3, 256, 32, 1e-10), (0.2, -1.2, 256, 32, 1e-8),
    # crossing the barrier top with 1e-4 of kinetic energy: a long stay at q ≈ 1/2, the
    # plateau that a learned shape missed; finer grid and rule converge
    (0.5, math.sqrt(2e-4), 256, 32, 1e-7), (0.5, math.sqrt(2e-4), 2048, 128, 1e-9),
    # 1e-6 above the top the peak of 1/|p| is narrower than a panel of 32: the period
    # itself needs the finer rule (with 32 panels L_tot is 1e-3)
    (0.5, math.sqrt(2e-6), 256, 128, 1e-5)])
def test_in_a_double_well_and_just_above_its_barrier_it_matches_an_independent_solve(
        q0, p0, grid, panels, bound):
    t = np.linspace(0, 2, 100)
    q, p = spline_trajectory(DOUBLE_WELL, q0, p0, t)
    net = computed(grid=grid, panels=panels)
    with torch.no_grad():
        y = net((rows(DOUBLE_WELL, q0, p0), torch.tensor(t)[:, None]))[0].numpy()
    L = 0.5 * (np.mean((y[:, 0] - q) ** 2) + np.mean((y[:, 1] - p) ** 2))
    assert L < bound, L


def test_compiled_rows_and_torch_formulas_agree_and_gradients_flow():
    V = np.repeat(DOUBLE_WELL[None], 4, 0)
    q0, p0 = np.array([0.2, 0.5, 0.7, 0.3]), np.array([0.3, 0.01, -0.8, -1.5])
    t = torch.linspace(0, 3, 40, dtype=torch.float64)[:, None]
    net = computed()
    with torch.no_grad():
        compiled = net((rows(V, q0, p0), t))
    x = rows(V, q0, p0).requires_grad_(True)   # a gradient asked: the torch formulas
    y = net((x, t))
    np.testing.assert_allclose(y.detach().numpy(), compiled.numpy(), atol=1e-12)
    (dq,) = torch.autograd.grad(y[..., 0].sum(), x)
    assert torch.isfinite(dq).all() and dq[:, -2:].abs().sum() > 0   # through (q0, p0)


def test_shape_table_inverts_a_known_phase():
    # f ≡ 1 on s: the half-phase is s / 2 and s(h) = 2h, so Q = (1 − cos 2πh)/2 and
    # P = T (π/2) sin(2πh): the harmonic orbit at T = 2
    s, w = np.polynomial.legendre.leggauss(32)
    s, w = torch.tensor((s + 1) / 2), torch.tensor(w / 2)
    f = torch.ones(1, 32, dtype=torch.float64)
    Q, P = shape_table(f, s, w, torch.tensor([2.0], dtype=torch.float64), 11)
    Qh, Ph = harmonic_shape(11)
    np.testing.assert_allclose(Q[0].numpy(), Qh.numpy(), atol=1e-14)
    np.testing.assert_allclose(P[0].numpy(), Ph.numpy(), atol=1e-12)


def test_the_shape_is_a_strategy_named_in_configs():
    assert start_shape("learned") == HarmonicStart()
    assert start_shape("quadrature") == QuadratureStart()
    assert start_shape(QuadratureStart()) == QuadratureStart()
    for cls in (PhaseONet, StatePhaseONet):
        with pytest.raises(ValueError, match="shape must be 'learned' or 'quadrature'"):
            cls(shape="exact")
    # the quadrature start zeroes the MLP's last layer: the start is the answer
    net = PhaseONet(width=8, depth=1, basis=4, grid=8, shape="quadrature")
    assert not net.branch[-1].weight.any() and not net.branch[-1].bias.any()
    assert PhaseONet(width=8, depth=1, basis=4, grid=8).branch[-1].weight.any()


def rest(nodes=64, grid=256):
    torch.manual_seed(0)
    net = PhaseONet(width=16, depth=1, basis=4, grid=grid, nodes=nodes, shape="quadrature")
    return cast_network(net, torch.float64).eval()


def test_at_rest_at_construction_it_is_the_exact_harmonic_orbit():
    V = 2 - W**2 * X * (1 - X) / 2      # from rest at q = 0: q = (1 − cos Wt)/2
    t = np.linspace(0, 5, 61)
    with torch.no_grad():
        y = rest(grid=2048)((torch.tensor(V[None]), torch.tensor(t)[:, None]))[0].numpy()
    np.testing.assert_allclose(y[:, 0], (1 - np.cos(W * t)) / 2, atol=2e-7)
    np.testing.assert_allclose(y[:, 1], W / 2 * np.sin(W * t), atol=2e-6)


def test_at_rest_it_converges_to_an_independent_solve_and_both_paths_agree():
    import nh_operators as nh

    space = nh.BoundedPotentialSpace(seed=11)
    V = np.asarray(space.eval_batch(space.random(3), nh.SENSORS[:, None], dtype=np.float64))
    t = np.linspace(0, 2, 100)
    errors = []
    for nodes, grid in ((32, 256), (64, 256), (128, 1024)):
        with torch.no_grad():
            y = rest(nodes, grid)((torch.tensor(V), torch.tensor(t)[:, None])).numpy()
        errors.append(max(0.5 * (np.mean((y[i, :, 0] - q) ** 2) + np.mean((y[i, :, 1] - p) ** 2))
                          for i, (q, p) in enumerate(spline_trajectory(v, 0.0, 0.0, t)
                                                     for v in V)))
    assert errors[2] < 1e-8 and errors[2] < errors[1] < errors[0], errors
    net, x = rest(), torch.tensor(V).requires_grad_(True)   # a gradient: torch formulas
    y = net((x, torch.tensor(t)[:, None]))
    with torch.no_grad():
        compiled = net((torch.tensor(V), torch.tensor(t)[:, None]))
    np.testing.assert_allclose(y.detach().numpy(), compiled.numpy(), atol=1e-12)
