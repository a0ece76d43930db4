"""MambONet: residual Mamba blocks over the potential, a transformer decoder over time."""

from typing import Optional, Sequence, Union

import torch
from torch import nn

from ._decoder import TimeDecoder
from ._layers import OperatorNet, SensorEmbedding, match_default_float, resolve_query_coupled
from .mamba import Mamba

__all__ = ["MambONet"]


class ResidualMamba(nn.Module):
    """Pre-norm residual block: x + Mamba(LayerNorm(x))."""

    def __init__(self, d_model, layer_idx=None, **mamba_kwargs):
        super().__init__()
        self.norm = nn.LayerNorm(d_model)
        self.mixer = Mamba(d_model, layer_idx=layer_idx, **mamba_kwargs)

    def forward(self, x):
        return x + self.mixer(self.norm(x))


class MambONet(OperatorNet):
    """Mamba operator network (the paper's §2.4).

    Sensor values are embedded by a shared Linear(1, d) (no positional encoding: the
    Mamba scan is ordered along q), pass through residual pre-norm Mamba blocks and a
    final LayerNorm, and form the memory of the same time decoder as
    :class:`~nh_operators.models.TraONet`. The Mamba blocks are
    :class:`~nh_operators.models.mamba.Mamba`: pure PyTorch with a fast CPU scan, and
    ``mamba_ssm``'s CUDA kernel on a GPU when it is installed (same weights).

    Args:
        d_model: token width d (paper: 128); even and divisible by ``nhead``.
        num_mamba_layers: Mamba blocks (paper: 4).
        nhead: decoder attention heads (paper: 4).
        num_decoder_layers: decoder layers (paper: 4).
        dim_feedforward: decoder feed-forward width (paper: 1024).
        d_state, d_conv, expand: Mamba's state size (16), convolution width (4) and
            expansion factor (2).
        dropout: decoder dropout (default 0).
        n_sensors, n_outputs, time_scale, query_dim, regularization: as
            :class:`~nh_operators.models.TraONet`.
        query_coupled, query_attention: as :class:`~nh_operators.models.TraONet`.
        norm_first, activation: as :class:`~nh_operators.models.TraONet`, for the
            decoder. The query points are embedded and scaled as TraONet's (see
            there: Linear(d, d_model) plus sinusoidal features of x_k · time_scale, the
            frequencies dealt to the d coordinates in turn); with
            ``query_coupled=False`` each is predicted on its own and ``dde.grad`` gives
            pointwise first and second derivatives.
        scaled_outputs: as :class:`~nh_operators.models.TraONet` (default False).
        initial_state: True: V carries (q0, p0) after the sensors, (B, m + 2), embedded
            as one token at the start of the scan (default False: rest at q = 0).
        state_in_queries: as :class:`~nh_operators.models.TraONet`.

    Raises:
        ValueError: for inconsistent options, as TraONet.

    References:
        A. Gu and T. Dao, "Mamba: linear-time sequence modeling with selective state
        spaces", arXiv:2312.00752 (2023). T.-G. Kim and S. C. Park, "Neural Hamilton:
        Can A.I. Understand Hamiltonian Mechanics?" (2024), §2.4.

    Example:
        >>> import torch
        >>> net = MambONet(d_model=16, num_mamba_layers=1, nhead=2,
        ...                num_decoder_layers=1, dim_feedforward=32)
        >>> net((torch.zeros(3, 100), torch.linspace(0, 2, 5)[:, None])).shape
        torch.Size([3, 5, 2])
    """

    query_coupled = True  # decoder self-attention over the query points (by default)

    def __init__(self, d_model: int = 128, num_mamba_layers: int = 4, nhead: int = 4,
                 num_decoder_layers: int = 4, dim_feedforward: int = 1024, d_state: int = 16,
                 d_conv: int = 4, expand: int = 2, dropout: float = 0.0,
                 n_sensors: int = 100, n_outputs: int = 2,
                 time_scale: Union[float, Sequence[float]] = 99 / 2,
                 query_attention: Optional[bool] = None, norm_first: bool = False,
                 activation: str = "relu", initial_state: bool = False,
                 state_in_queries: bool = False, scaled_outputs: bool = False,
                 query_coupled: Optional[bool] = None, query_dim: int = 1,
                 regularization=None):
        super().__init__()
        self.regularizer = regularization
        query_attention = resolve_query_coupled(query_coupled, query_attention)
        self.query_dim = query_dim
        self.initial_state = bool(initial_state)
        self._state_modules(d_model, state_in_queries)
        self.n_sensors = n_sensors
        self.n_outputs = n_outputs
        self.query_coupled = bool(query_attention)
        self.embedding = SensorEmbedding(d_model, positional=False)
        self.blocks = nn.ModuleList(
            ResidualMamba(d_model, layer_idx=i, d_state=d_state, d_conv=d_conv,
                          expand=expand)
            for i in range(num_mamba_layers))
        self.norm = nn.LayerNorm(d_model)
        self.decoder = TimeDecoder(d_model, nhead, num_decoder_layers, dim_feedforward,
                                   n_outputs, dropout, time_scale, query_attention,
                                   norm_first, activation, scaled_outputs, query_dim)
        match_default_float(self)

    def _forward(self, V, t):
        V, state = self._sensors_and_state(V)
        h = self.embedding(V)
        if state is not None:  # first in the scan, so every sensor token sees it
            h = torch.cat([self.state_embedding(state), h], dim=1)
        for block in self.blocks:
            h = block(h)
        return self.decoder(t, self.norm(h), self._query_bias(state))
