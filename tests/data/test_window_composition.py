"""The window mode of benchmarks/physics/without_labels.py composes a flow map over short
windows (``benchmarks/physics/windows.py``): with the exact flow of a harmonic well as
the "network", the composed trajectory is the exact one, whatever the window."""

import sys
from pathlib import Path

import numpy as np
import pytest
import torch

import nh_operators as nh

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks" / "physics"))
from windows import composed, one_window_medians, window_physics  # noqa: E402

OMEGA = 4.0  # V = 2 - 8 q (1 - q): V'' = 16


class HarmonicFlow(torch.nn.Module):
    """The exact flow of V = 2 − 8q(1 − q) from (q0, p0), read from the input's last two
    columns, at the times τ: the contract of a network that reads a state."""

    def __init__(self) -> None:
        super().__init__()
        self.unused = torch.nn.Parameter(torch.zeros(1))

    def forward(self, inputs):
        V, tau = inputs
        q0, p0 = V[:, -2:-1], V[:, -1:]
        c, s = torch.cos(OMEGA * tau[:, 0]), torch.sin(OMEGA * tau[:, 0])
        q = 0.5 + (q0 - 0.5) * c + p0 / OMEGA * s
        p = -OMEGA * (q0 - 0.5) * s + p0 * c
        return torch.stack([q, p], -1)


@pytest.mark.parametrize("window", [0.25, 0.3, 2.0, 5.0])
def test_an_exact_flow_composes_to_the_exact_trajectory(window: float) -> None:
    V = np.tile(2 - 8 * nh.SENSORS * (1 - nh.SENSORS), (3, 1))
    q, p = composed(HarmonicFlow(), V, nh.TIMES, window)
    t = nh.TIMES
    np.testing.assert_allclose(q, np.broadcast_to(0.5 - 0.5 * np.cos(OMEGA * t), q.shape),
                               atol=1e-13)
    np.testing.assert_allclose(p, np.broadcast_to(2.0 * np.sin(OMEGA * t), p.shape),
                               atol=1e-12)


def test_one_window_from_the_true_states_is_exact_for_the_exact_flow() -> None:
    t = nh.TIMES
    V = np.tile(2 - 8 * nh.SENSORS * (1 - nh.SENSORS), (2, 1))
    labels = type("Data", (), {"t": t, "V": V,
                               "q": np.tile(0.5 - 0.5 * np.cos(OMEGA * t), (2, 1)),
                               "p": np.tile(2.0 * np.sin(OMEGA * t), (2, 1))})()
    errors = one_window_medians(HarmonicFlow().double(), labels, 0.25)
    assert len(errors) == 8 and max(errors) < 1e-26


def test_the_window_modes_physics_counts_only_the_window() -> None:
    terms = nh.data.PhysicsTerms(**window_physics(0.25, 1.0))
    assert terms.horizon(0) == 0.25 / 8 and terms.horizon(1) == terms.horizon(10**6) == 0.25
    assert terms.t_max == 0.25 and terms.extra_times == 64 and terms.energy == 1.0
