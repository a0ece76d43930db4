"""MambONet: residual Mamba blocks over the potential, a transformer decoder over time."""

import torch
from torch import nn

from ._layers import OperatorNet, SensorEmbedding, TimeDecoder
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
        n_sensors, n_outputs, time_scale, query_attention, norm_first, activation: as
            :class:`~nh_operators.models.TraONet` (the last two for the decoder).
        scaled_outputs: as :class:`~nh_operators.models.TraONet` (default False).
        initial_state: True: V carries (q0, p0) after the sensors, (B, m + 2), embedded
            as one token at the start of the scan (default False: rest at q = 0).
        state_in_queries: as :class:`~nh_operators.models.TraONet`.

    Example:
        >>> import torch
        >>> net = MambONet(d_model=16, num_mamba_layers=1, nhead=2,
        ...                num_decoder_layers=1, dim_feedforward=32)
        >>> net((torch.zeros(3, 100), torch.linspace(0, 2, 5)[:, None])).shape
        torch.Size([3, 5, 2])
    """

    query_coupled = True  # decoder self-attention over the query times (by default)

    def __init__(self, d_model=128, num_mamba_layers=4, nhead=4, num_decoder_layers=4,
                 dim_feedforward=1024, d_state=16, d_conv=4, expand=2, dropout=0.0,
                 n_sensors=100, n_outputs=2, time_scale=99 / 2, query_attention=True,
                 norm_first=False, activation="relu", initial_state=False,
                 state_in_queries=False, scaled_outputs=False):
        super().__init__()
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
                                   norm_first, activation, scaled_outputs)

    def _forward(self, V, t):
        V, state = self._sensors_and_state(V)
        h = self.embedding(V)
        if state is not None:  # first in the scan, so every sensor token sees it
            h = torch.cat([self.state_embedding(state), h], dim=1)
        for block in self.blocks:
            h = block(h)
        return self.decoder(t, self.norm(h), self._query_bias(state))
