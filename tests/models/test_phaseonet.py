"""PhaseONet: the period quadrature against exact periods, the structure of its outputs
(T-periodic, q even and p odd in time, the harmonic orbit at zero weights), its float64
rule as buffers, and the factory behind ``build_model("phaseonet")``."""

import math

import numpy as np
import pytest
import torch
from scipy.integrate import quad

import nh_operators as nh
from nh_operators.models import PhaseONet, StatePhaseONet, cast_network, period_quadrature
from nh_operators.models.phase_start import QuadratureStart
from nh_operators.solvers.periodic import orbit_periods
from nh_operators.solvers.rows import row_source

X = torch.linspace(0, 1, 100, dtype=torch.float64)


def net64(seed=0, **kw):
    torch.manual_seed(seed)
    return cast_network(PhaseONet(**{"width": 32, "depth": 2, "basis": 8, **kw}),
                        torch.float64).eval()


def test_period_of_the_harmonic_well_is_pi_over_two():
    # V = 2 − 8q(1 − q): ω = 4; the spline of a quadratic is exact.
    T = net64().period((2 - 8 * X * (1 - X))[None])
    assert T.item() == pytest.approx(math.pi / 2, rel=1e-13)


def test_period_of_a_cubic_well_matches_adaptive_quadrature():
    # A cubic is reproduced exactly by the sensor spline, so the only error is the
    # Gauss–Legendre rule's.
    V = lambda q: 2 - 5 * q * (1 - q) * (1 + 0.8 * q)  # noqa: E731
    exact = 2 * quad(lambda q: 1 / math.sqrt(2 * (2 - V(q))), 0, 1, epsabs=0,
                     epsrel=1e-13, limit=200)[0]
    T = net64().period(V(X)[None])
    assert T.item() == pytest.approx(exact, rel=1e-10)


def test_period_of_generator_potentials_matches_the_orbit_solver():
    # Independent method: the classical orbit period of the sensor spline.
    space = nh.BoundedPotentialSpace(seed=4)
    V = space.eval_batch(space.random(6), nh.SENSORS[:, None], dtype=np.float64)
    ours = net64().period(torch.as_tensor(V)).numpy()
    out, status = orbit_periods(row_source(np.asarray(V), "sensors"), np.arange(6),
                                np.zeros(6), np.zeros(6))
    assert np.all(status == 0)
    np.testing.assert_allclose(ours, out[:, 0], rtol=3e-5)


def test_outputs_are_periodic_even_and_odd_for_any_weights():
    net = net64(seed=3)
    V = torch.stack([2 - 8 * X * (1 - X), 2 - 5 * X * (1 - X) * (1 + 0.8 * X)])
    T = net.period(V)
    s = torch.tensor([0.05, 0.3, 0.61], dtype=torch.float64)
    with torch.no_grad():
        for i in range(2):
            at = lambda t: net((V[i:i + 1], t[:, None]))[0]  # noqa: E731
            y, shifted, mirrored = at(s), at(s + 3 * T[i]), at(T[i] - s)
            torch.testing.assert_close(shifted, y, rtol=0, atol=1e-12)
            torch.testing.assert_close(mirrored[:, 0], y[:, 0], rtol=0, atol=1e-12)
            torch.testing.assert_close(mirrored[:, 1], -y[:, 1], rtol=0, atol=1e-12)


def test_zero_coefficients_give_the_harmonic_orbit_within_the_interpolation_bound():
    grid = 256
    net = net64(grid=grid)
    with torch.no_grad():
        for p in net.branch[-1].parameters():
            p.zero_()
        t = torch.linspace(0, 40, 999, dtype=torch.float64)  # past 16: float64 phase
        q = net(((2 - 8 * X * (1 - X))[None], t[:, None]))[0, :, 0]
    exact = (1 - torch.cos(4 * t)) / 2
    # linear interpolation of (1 − cos 2πh)/2 on step 1/(2(grid − 1)): ≤ step²/8 · 2π²
    bound = (0.5 / (grid - 1)) ** 2 / 8 * 2 * math.pi ** 2
    assert (q - exact).abs().max().item() <= bound
    assert (q - exact).abs().max().item() > bound / 10  # the bound is not vacuous


@pytest.mark.parametrize("kw, message", [
    (dict(grid=1), "grid ≥ 2"),
    (dict(basis=0), "positive basis"),
    (dict(activation="swish"), "unknown activation 'swish'"),
    (dict(shape="exact"), "shape must be 'learned' or 'quadrature'"),
    (dict(n_outputs=3), r"serves only the 1-D Hamiltonian problem: n_outputs must be 1 or 2"),
    (dict(query_dim=2), (r"serves only the 1-D Hamiltonian problem: its query points are "
                         r"times \(query_dim=1\), got query_dim=2; .*'deeponet'")),
    (dict(query_coupled=True), "answers each time on its own"),
])
def test_bad_arguments_are_named(kw, message):
    with pytest.raises(ValueError, match=message):
        PhaseONet(**kw)


def test_the_state_dict_holds_only_trained_tensors():
    keys = set(PhaseONet(width=8, depth=1, basis=4, grid=8).state_dict())
    assert keys == {"basis", "branch.0.weight", "branch.0.bias", "branch.2.weight",
                    "branch.2.bias"}


def test_the_rule_stays_float64_through_casts_and_follows_the_device():
    net = PhaseONet(width=8, depth=1, basis=4, grid=8)
    exact = torch.tensor(-2 * period_quadrature(100, 64)[0])
    for cast in (lambda n: cast_network(n, torch.float64), lambda n: n.float(),
                 lambda n: n.half()):
        rule = cast(net).quadrature
        assert rule.matrix.dtype == torch.float64 and torch.equal(rule.matrix, exact)
        assert rule.period_weights.dtype == torch.float64
    assert net.basis.dtype == torch.float16           # the network itself was cast
    moved = net.to("meta")                            # .to(device) moves the rule
    assert {b.device.type for b in moved.quadrature.buffers()} == {"meta"}
    assert moved.quadrature.matrix.dtype == torch.float64


def test_the_factory_builds_the_network_of_the_config():
    rest = nh.build_model("phaseonet", "cpu", width=8, depth=1, basis=4, grid=8,
                          regularization=["l2", 1e-5])
    state = nh.build_model("phaseonet", "cpu", width=8, depth=1, basis=4, grid=8,
                           initial_state=True, shape="quadrature", panels=4)
    assert type(rest) is PhaseONet and rest.regularizer == ["l2", 1e-5]
    assert type(state) is StatePhaseONet and isinstance(state.start, QuadratureStart)
    assert state.quadrature.rule_nodes.numel() == 4 * 16
    assert not rest.initial_state and state.initial_state
    with pytest.raises(ValueError, match="panels .* needs initial_state=True"):
        nh.build_model("phaseonet", "cpu", panels=4)
    with pytest.raises(ValueError, match=r"no argument\(s\) \['head'\]"):
        nh.build_model("phaseonet", "cpu", head="time")
    with pytest.raises(ValueError, match="StatePhaseONet serves only the 1-D Hamiltonian "
                                         "problem: n_outputs must be 2"):
        nh.build_model("phaseonet", "cpu", initial_state=True, n_outputs=1)


def test_one_output_is_the_first_of_two():
    torch.manual_seed(2)
    two = PhaseONet(width=8, depth=1, basis=4, grid=16)
    one = PhaseONet(width=8, depth=1, basis=4, grid=16, n_outputs=1)
    with torch.no_grad():     # the same MLP rows for q, the same basis row
        one.branch[0].load_state_dict(two.branch[0].state_dict())
        one.branch[2].weight.copy_(two.branch[2].weight[:4])
        one.branch[2].bias.copy_(two.branch[2].bias[:4])
        one.basis.copy_(two.basis[:1])
    V, t = (2 - 8 * X * (1 - X))[None].float(), torch.linspace(0, 3, 9)[:, None]
    with torch.no_grad():
        assert one((V, t)).shape == (1, 9)
        torch.testing.assert_close(one((V, t)), two((V, t))[..., 0], rtol=0, atol=0)
