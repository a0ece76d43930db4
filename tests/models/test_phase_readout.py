"""PhaseONet's compiled read-out: the torch read-out's numbers, the phase in float64."""

import numba
import numpy as np
import pytest
import torch

import nh_operators as nh
from nh_operators.models import build_model
from nh_operators.models import phase_readout
from nh_operators.models.phase_readout import read_orbit_rows


def _sensors(n: int, seed: int) -> torch.Tensor:
    space = nh.BoundedPotentialSpace(seed=seed)
    return torch.tensor(space.potentials(space.random(n)).V(nh.SENSORS))


def test_read_orbit_rows_on_a_linear_table_is_exact():
    # Q(h) = 2h and P(h) = 1 − 2h on 5 nodes: linear, so the lerp is exact anywhere
    h = np.linspace(0.0, 0.5, 5)
    q, p = (2 * h)[None], (1 - 2 * h)[None]
    t = np.array([0.0, 0.1, 0.3, 0.5, 0.7, 1.0, 1.25, 2.6])
    out = read_orbit_rows(q, p, np.array([1.0]), np.zeros(1), t, 2)
    u = t % 1.0
    half = 0.5 - np.abs(u - 0.5)
    sign = np.where(u < 0.5, 1.0, np.where(u > 0.5, -1.0, 0.0))
    np.testing.assert_allclose(out[0, :, 0], 2 * half, atol=1e-15)
    np.testing.assert_allclose(out[0, :, 1], sign * (1 - 2 * half), atol=1e-15)
    # an offset shifts the phase; one output reads Q only
    shifted = read_orbit_rows(q, q, np.array([1.0]), np.array([0.25]), t, 1)
    assert shifted.shape == (1, 8, 1)
    np.testing.assert_allclose(shifted[0, :, 0], 2 * (0.5 - np.abs((t + 0.25) % 1 - 0.5)),
                               atol=1e-15)


@pytest.mark.parametrize("shape", ["learned", "quadrature"])
@pytest.mark.parametrize("initial_state", [False, True])
def test_no_grad_forward_equals_the_torch_read_out_in_float64(shape, initial_state):
    torch.manual_seed(0)
    net = build_model("phaseonet", width=16, depth=1, basis=6, grid=32, shape=shape,
                      initial_state=initial_state).double()
    V = _sensors(50, seed=3)
    if initial_state:
        V = torch.cat([V, torch.full((50, 1), 0.2, dtype=torch.float64),
                       torch.linspace(-0.5, 0.5, 50, dtype=torch.float64)[:, None]], 1)
    t = torch.linspace(0, 40, 81, dtype=torch.float64)[:, None]   # beyond t = 16 too
    with torch.no_grad():
        fast = net((V, t))
    reference = net((V, t))         # parameters need a gradient: the torch read-out
    assert reference.requires_grad and not fast.requires_grad
    assert fast.shape == (50, 81, 2)
    np.testing.assert_allclose(fast.numpy(), reference.detach().numpy(), rtol=0,
                               atol=1e-14)


def test_float32_forward_differs_from_torch_by_the_float32_phase_only():
    # torch's path takes t / T in float32 below t = 16: a phase error of 6e-8 relative,
    # times the slope of the orbit on the grid; the compiled path takes it in float64
    net = nh.pretrained("phaseonet-alg1-quadrature").net
    V = _sensors(200, seed=4).float()
    t = torch.tensor(nh.TIMES, dtype=torch.float32)[:, None]
    with torch.no_grad():
        fast = net((V, t))
    reference = net((V, t)).detach()
    assert fast.dtype == torch.float32
    gap = (fast - reference).abs().max().item()
    assert 0 < gap < 3e-5
    # the float64 phase is no worse against the exact trajectories of the B-splines
    space = nh.BoundedPotentialSpace(seed=4)
    exact = nh.solve_many(space.potentials(space.random(200)), nh.TIMES, tol=1e-12,
                          method="classical")

    def median_l_tot(out: torch.Tensor) -> float:
        y = out.double().numpy()
        return float(np.median(0.5 * (np.mean((y[..., 0] - exact.q) ** 2, 1)
                                      + np.mean((y[..., 1] - exact.p) ** 2, 1))))

    assert median_l_tot(fast) <= 1.01 * median_l_tot(reference)
    assert median_l_tot(fast) < 1e-5


def test_parallel_rows_equal_the_serial_rows_exactly(monkeypatch):
    rng = np.random.default_rng(0)
    q, p = rng.random((3 * phase_readout.PARALLEL_FROM, 17)), rng.random((192, 17))
    rate, offset = rng.uniform(0.3, 1.0, 192), rng.uniform(0.0, 1.0, 192)
    t = np.linspace(0.0, 5.0, 33)
    out = np.empty((192, 33, 2))
    phase_readout._rows_serial(q, p, rate, offset, t, out)
    parallel = np.empty_like(out)
    phase_readout._rows_parallel(q, p, rate, offset, t, parallel)
    assert np.array_equal(out, parallel)
    if numba.config.NUMBA_NUM_THREADS > 1:
        assert np.array_equal(read_orbit_rows(q, p, rate, offset, t, 2), out)
