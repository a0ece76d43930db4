"""StatePhaseONet, PhaseONet from a starting state: the orbit's turning points, period and phase against
exact and independent ones, the exact harmonic trajectory at zero weights, and the rest
scene as a special case."""

import math

import numpy as np
import pytest
import torch
from scipy.integrate import quad
from scipy.interpolate import CubicSpline

import nh_operators as nh
from nh_operators.models import PhaseONet, StatePhaseONet, cast_network
from nh_operators.models import orbit_coordinates as orbits
from nh_operators.solvers import STATE_UNIFORMS, energy_states
from nh_operators.solvers.periodic import orbit_periods
from nh_operators.solvers.rows import row_source

X = np.linspace(0, 1, 100)
W = 4.0  # V = 2 − W² q (1 − q) / 2: harmonic about q = 1/2 with frequency W


def net64(seed=0, **kw):
    torch.manual_seed(seed)
    net = StatePhaseONet(**{"width": 32, "depth": 2, "basis": 8, **kw})
    return cast_network(net, torch.float64).eval()


def harmonic(grid):
    """A network at zero output weights (the harmonic orbit through any state) and the
    harmonic well's sensor values."""
    net = net64(grid=grid)
    with torch.no_grad():
        net.branch[-1].weight.zero_()
        net.branch[-1].bias.zero_()
    return net, 2 - W**2 * X * (1 - X) / 2


def rows(V, q0, p0):
    V = np.atleast_2d(V)
    n = len(V)
    return torch.tensor(np.column_stack([V, np.broadcast_to(q0, n), np.broadcast_to(p0, n)]))


def sho(q0, p0, t):
    c = q0 - 0.5
    return (0.5 + c * np.cos(W * t) + p0 / W * np.sin(W * t),
            -c * W * np.sin(W * t) + p0 * np.cos(W * t))


def test_the_harmonic_orbit_from_any_state_has_exact_ends_period_and_phase():
    V = 2 - W**2 * X * (1 - X) / 2
    q0, p0 = np.array([0.3, 0.6, 0.5, 0.0]), np.array([0.5, -0.7, 0.0, 0.0])
    o = net64().state_orbit(rows(np.repeat(V[None], 4, 0), q0, p0))
    E = 0.5 * p0**2 + 2 - W**2 * q0 * (1 - q0) / 2
    amplitude = np.sqrt(2 * (E - (2 - W**2 / 8))) / W
    np.testing.assert_allclose(o["a"].numpy(), 0.5 - amplitude, atol=1e-13)
    np.testing.assert_allclose(o["b"].numpy(), 0.5 + amplitude, atol=1e-13)
    np.testing.assert_allclose(o["T"].numpy(), 2 * math.pi / W, rtol=1e-11)
    # time from the left end a to q0 on q = 1/2 − A cos(W τ) (row 2 rests at the
    # bottom: no orbit, and the harmonic limit's period)
    moving = [0, 1, 3]
    tau = np.arccos((0.5 - q0[moving]) / amplitude[moving]) / W
    u0 = np.where(p0[moving] >= 0, tau, 2 * math.pi / W - tau) * W / (2 * math.pi)
    np.testing.assert_allclose(o["u0"].numpy()[moving], u0, atol=1e-12)


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_period_and_phase_in_a_double_well_match_adaptive_quadrature():
    # below the barrier: the orbit stays in the left well; above: it spans both
    V = 2 - 40 * X**2 * (1 - X) ** 2 * (0.1 + 8 * (X - 0.5) ** 2)  # wells near 0.22, 0.78
    spline = CubicSpline(X, V)
    # the third crosses the barrier top at 1/2 with 1e-4 of kinetic energy: a slow
    # passage, a peak of 1/|p| inside [a, b] that a single 64-node rule misses
    for q0, p0 in ((0.2, 0.3), (0.2, -1.2), (0.5, math.sqrt(2e-4))):
        o = {k: v.item() for k, v in net64().state_orbit(rows(V, q0, p0)).items()
             if k != "U"}
        E, a, b = o["E"], o["a"], o["b"]
        assert E == pytest.approx(0.5 * p0**2 + spline(q0), abs=1e-14)
        assert spline(a) == pytest.approx(E, abs=1e-12) and spline(b) == pytest.approx(E, abs=1e-12)
        assert a < q0 < b and np.all(spline(np.linspace(a, b, 2001)[1:-1]) < E)
        speed = lambda q: 1 / math.sqrt(2 * (E - spline(q)))  # noqa: E731
        T = 2 * quad(speed, a, b, epsabs=0, epsrel=1e-12, limit=500, points=[0.5])[0]
        tau = quad(speed, a, q0, epsabs=0, epsrel=1e-12, limit=500)[0]
        assert o["T"] == pytest.approx(T, rel=1e-5)
        assert o["u0"] == pytest.approx(tau / T if p0 >= 0 else 1 - tau / T, abs=1e-5)
    low = net64().state_orbit(rows(V, 0.2, 0.3))
    assert low["b"].item() < 0.5 < net64().state_orbit(rows(V, 0.2, -1.2))["b"].item()


def test_periods_from_generator_states_match_the_orbit_solver():
    # Independent method: the classical orbit period of the sensor spline from a state.
    space = nh.BoundedPotentialSpace(seed=5)
    V = np.asarray(space.eval_batch(space.random(8), nh.SENSORS[:, None], dtype=np.float64))
    src = row_source(V, "sensors")
    q0, p0, _ = energy_states(src.values_at, np.random.default_rng(3).random((8, STATE_UNIFORMS)),
                              separatrix_share=0.0)
    ours = net64().state_orbit(rows(V, q0, p0))["T"].numpy()
    out, status = orbit_periods(src, np.arange(8), q0, p0)
    ok = status == 0
    assert ok.sum() >= 6
    np.testing.assert_allclose(ours[ok], out[ok, 0], rtol=3e-5)


def test_zero_coefficients_give_the_exact_harmonic_trajectory_from_a_state():
    net, V = harmonic(grid=2048)
    t = np.linspace(0, 5, 61)   # past one period: the phase runs on
    for q0, p0 in ((0.3, -0.5), (0.45, 0.9), (0.5, 0.0)):
        with torch.no_grad():
            y = net((rows(V, q0, p0), torch.tensor(t)[:, None]))[0].numpy()
        q, p = sho(q0, p0, t)
        # linear interpolation on 2048 nodes: error ≤ (1/4094)² / 8 · max Q'' · (b − a)
        np.testing.assert_allclose(y[:, 0], q, atol=5e-7)
        np.testing.assert_allclose(y[:, 1], p, atol=5e-6)


def test_at_rest_the_orbit_is_the_rest_scene():
    space = nh.BoundedPotentialSpace(seed=6)
    V = np.asarray(space.eval_batch(space.random(4), nh.SENSORS[:, None], dtype=np.float64))
    o = net64().state_orbit(rows(V, 0.0, 0.0))
    np.testing.assert_allclose(o["a"].numpy(), 0.0, atol=1e-14)
    np.testing.assert_allclose(o["b"].numpy(), 1.0, atol=1e-14)
    np.testing.assert_allclose(o["u0"].numpy(), 0.0, atol=1e-14)
    torch.manual_seed(0)
    rest = PhaseONet(width=32, depth=2, basis=8).period(torch.tensor(V))
    # the rest head's 64 Gauss–Legendre nodes against the state head's 32 × 16
    np.testing.assert_allclose(o["T"].numpy(), rest.numpy(), rtol=1e-5)
    single = net64(panels=1).state_orbit(rows(V, 0.0, 0.0))["T"]   # 16 nodes
    assert np.abs(single.numpy() / o["T"].numpy() - 1).max() > 1e-7


def test_the_state_network_is_named_where_it_cannot_apply():
    with pytest.raises(ValueError, match="StatePhaseONet serves only the 1-D Hamiltonian "
                                         r"problem: n_outputs must be 2 \(q and p\)"):
        StatePhaseONet(n_outputs=1)
    with pytest.raises(ValueError, match="query_dim=3"):
        StatePhaseONet(query_dim=3)
    net = net64()
    with pytest.raises(ValueError, match=r"V must have shape \(batch, 102\)"):
        net((torch.zeros(1, 100, dtype=torch.float64), torch.zeros(3, 1, dtype=torch.float64)))
    built = nh.build_model("phaseonet", "cpu", initial_state=True)
    assert built.initial_state and built.branch[0].in_features == 64 + 1


def test_the_flow_jacobian_goes_through_the_orbit_by_autograd():
    # zero weights: the harmonic orbit, whose flow map is linear with
    # J = [[cos Wt, sin(Wt)/W], [−W sin Wt, cos Wt]]
    from nh_operators.evaluation import network_jacobian

    net, V = harmonic(grid=4096)
    t = np.array([0.3, 1.1, 1.9])
    J = network_jacobian(net, V[None], np.array([0.35]), np.array([0.6]), t)[0]
    c, s = np.cos(W * t), np.sin(W * t)
    exact = np.stack([np.stack([c, s / W], -1), np.stack([-W * s, c], -1)], -2)
    np.testing.assert_allclose(J, exact, atol=2e-3)
    np.testing.assert_allclose(np.linalg.det(J), 1.0, atol=2e-3)


def test_a_method_passes_states_to_a_network_that_reads_them_and_refuses_otherwise():
    from nh_operators.evaluation import NeuralMethod

    V = (2 - W**2 * X * (1 - X) / 2)[None].repeat(2, 0)
    method = NeuralMethod(net64(), "phase", domain_check=False)
    q, p = method(V, nh.TIMES[:5], q0=[0.3, 0.0], p0=[0.5, 0.0])
    with torch.no_grad():
        direct = method.net((rows(V, [0.3, 0.0], [0.5, 0.0]),
                             torch.tensor(nh.TIMES[:5])[:, None])).numpy()
    np.testing.assert_allclose(q, direct[..., 0], rtol=1e-12)
    rest = method(V, nh.TIMES[:5])   # default: the rest state
    np.testing.assert_allclose(rest[0][1], q[1], rtol=1e-12)
    plain = NeuralMethod(PhaseONet(width=8, depth=1, basis=4), "plain", domain_check=False)
    with pytest.raises(ValueError, match=r"trained from the state \(0, 0\) only"):
        plain(V, nh.TIMES[:5], q0=0.3, p0=0.5)


def test_the_compiled_brackets_are_the_torch_brackets_bit_for_bit():
    space = nh.BoundedPotentialSpace(seed=11)
    V = torch.tensor(space.potentials(space.random(200)).V(nh.SENSORS))
    spline = orbits.SensorSpline()
    coef_map, grid_map, grid = spline.maps()
    c, values = V @ coef_map, V @ grid_map
    rng = np.random.default_rng(0)
    q0 = torch.tensor(rng.uniform(0.01, 0.99, 200))
    V0q = spline.at(c, q0[:, None])[:, 0]
    # energies from just above V(q0) (narrow orbits) to above V0 (open to both walls)
    E = V0q + torch.tensor(np.concatenate([rng.uniform(0, 1e-9, 50), rng.uniform(0, 1, 100),
                                           rng.uniform(3, 5, 50)]))
    compiled = orbits._brackets(spline, c, values, grid, q0, E, 48, compiled=True)
    plain = orbits._brackets(spline, c, values, grid, q0, E, 48, compiled=False)
    for x, y in zip(compiled, plain):
        assert x.dtype == y.dtype and torch.equal(x, y)
    left, right = plain[2], plain[3]
    assert (left == -1).any() and (right == grid.numel()).any()  # open ends were tried


def test_the_compiled_quadrature_agrees_with_the_differentiable_one():
    # without a gradient to carry the CPU takes one compiled pass; with one (the flow
    # Jacobian) the torch formulas run: both must give the same orbit
    space = nh.BoundedPotentialSpace(seed=12)
    V = torch.tensor(space.potentials(space.random(100)).V(nh.SENSORS))
    values = row_source(V.numpy(), "sensors").values_at
    q0, p0, _ = energy_states(values, np.random.default_rng(3).random((100, STATE_UNIFORMS)))
    q0, p0 = torch.tensor(q0), torch.tensor(p0)
    spline = orbits.SensorSpline()
    s = torch.tensor((np.polynomial.legendre.leggauss(64)[0] + 1) / 2)
    rule = orbits.composite_rule(32, 16)
    fast = orbits.orbit(spline, V, q0, p0, s, rule)
    slow = orbits.orbit(spline, V, q0.clone().requires_grad_(), p0, s, rule)
    assert torch.isfinite(fast["T"]).all()
    for key in ("T", "u0", "U"):
        np.testing.assert_allclose(fast[key].numpy(), slow[key].detach().numpy(),
                                   rtol=1e-12, atol=1e-300)
