"""PhaseONet: the period quadrature against exact periods, and the structure of its
outputs (T-periodic, q even and p odd in time, the harmonic orbit at zero weights)."""

import math

import numpy as np
import pytest
import torch
from scipy.integrate import quad

import nh_operators as nh
from nh_operators.models import PhaseONet, cast_network
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
    V = space.eval_batch(space.random(6), nh.SENSORS[:, None])
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


def test_time_head_ignores_the_period_in_its_read_out():
    net = net64(head="time")
    V = (2 - 8 * X * (1 - X))[None]
    with torch.no_grad():
        y = net((V, torch.tensor([[2.0], [3.0], [7.0]], dtype=torch.float64)))[0]
    torch.testing.assert_close(y[1], y[0])  # past the horizon: the last node
    torch.testing.assert_close(y[2], y[0])


@pytest.mark.parametrize("kw, message", [
    (dict(grid=1), "grid ≥ 2"),
    (dict(basis=0), "positive basis"),
    (dict(activation="swish"), "unknown activation 'swish'"),
    (dict(head="space"), "head must be 'phase' or 'time'"),
    (dict(n_outputs=3), "n_outputs must be 1 or 2"),
])
def test_bad_arguments_are_named(kw, message):
    with pytest.raises(ValueError, match=message):
        PhaseONet(**kw)


def test_the_state_dict_holds_only_trained_tensors():
    keys = set(PhaseONet(width=8, depth=1, basis=4, grid=8).state_dict())
    assert keys == {"basis", "branch.0.weight", "branch.0.bias", "branch.2.weight",
                    "branch.2.bias"}
