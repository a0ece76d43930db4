"""The ablation control of ``fast_operator.py``'s row ``head-time``: PhaseONet's MLP and
period feature, but the trajectory predicted on a grid of time instead of phase.

The same branch MLP over (V, log T) gives coefficients of a trainable basis, initialised
to cos and sin of πmt/``horizon``, on a uniform grid of t ∈ [0, ``horizon``] (q and p
start at zero); the period is only an input feature, and times past ``horizon`` take
the last node's value. Built from the library's public pieces
(:class:`~nh_operators.models.phase_head.BasisHeadNet`,
:class:`~nh_operators.models.phase_rules.RestQuadrature`); trained and loaded through
``nh.train`` / ``nh.load_model`` under the registry name ``phaseonet`` while
:func:`registered` holds.
"""

import contextlib
from collections.abc import Iterator
from unittest import mock

import numpy as np
import torch

from nh_operators import V0
from nh_operators.models import MODELS
from nh_operators.models.phase_head import BasisHeadNet, grid_lerp
from nh_operators.models.phase_rules import RestQuadrature

__all__ = ["TimeHeadONet", "registered"]


class TimeHeadONet(BasisHeadNet):
    """PhaseONet's MLP with a head in time: the control of the phase head's ablation.

    Args:
        width, depth, basis, grid, nodes, activation, n_sensors: as in
            :class:`~nh_operators.models.PhaseONet`.
        horizon: the time grid's end (default 2).

    Example:
        >>> net = TimeHeadONet(width=8, depth=1, basis=4, grid=16)
        >>> V = 8 * (torch.linspace(0, 1, 100) - 0.5) ** 2
        >>> net((V[None], torch.linspace(0, 2, 5)[:, None])).shape
        torch.Size([1, 5, 2])
    """

    def __init__(self, width: int = 128, depth: int = 2, basis: int = 32, grid: int = 256,
                 nodes: int = 64, activation: str = "gelu", horizon: float = 2.0,
                 n_sensors: int = 100) -> None:
        angle = np.pi * np.linspace(0.0, 1.0, grid)
        m = np.arange(basis)[:, None]
        harmonics = np.stack([np.cos(m * angle), np.sin((m + 1) * angle)])
        super().__init__(n_sensors + 1, harmonics, np.zeros((2, grid)), width=width,
                         depth=depth, activation=activation, n_sensors=n_sensors)
        self.horizon = float(horizon)
        self.quadrature = RestQuadrature(n_sensors, nodes)

    def _forward(self, V: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        T = self.quadrature.period(V)
        x = torch.cat([(V0 - V) / 2, torch.log(T).to(V.dtype)[:, None]], dim=1)
        coeffs = self.branch(x)
        tables = self.shape_tables(coeffs, self.start_tables())
        at = (t[:, 0] * ((self.grid - 1) / self.horizon)).to(coeffs.dtype)
        return torch.stack(grid_lerp(tables, at[None, :].expand(len(V), -1)), dim=-1)


@contextlib.contextmanager
def registered() -> Iterator[None]:
    """Build :class:`TimeHeadONet` for the registry name ``phaseonet`` while it holds
    (the row's run directory records that name; ``nh.load_model`` rebuilds it the same
    way inside the block)."""
    with mock.patch.dict(MODELS, {"phaseonet": TimeHeadONet}):
        yield
