"""The authors' TraONet and MambONet (reference code at 5c4cbd8), as DeepXDE networks.

As for :mod:`~nh_operators.models.reference_nets`: the same functions as the authors'
networks, under their ``state_dict`` key names.
"""

import math
from typing import cast

from torch import nn

from ._layers import OperatorNet
from ._reference_layers import PositionalEncoding, ReferenceTrunk, ResidualBlock
from .mamba import Mamba

__all__ = ["ReferenceTraONet", "ReferenceMambONet"]


class _TransformerBranch(nn.Module):
    """Sensor tokens Linear(1, d)(V_j) · √d + the table's row j, then a post-norm
    encoder with a final LayerNorm (``encoder_layer`` is the unused template)."""

    def __init__(self, d_model, nhead, num_layers, dim_feedforward, dropout, max_len):
        super().__init__()
        self.d_model = d_model
        self.embedding = nn.Linear(1, d_model)
        self.pos_encoder = PositionalEncoding(d_model, max_len)
        self.encoder_layer = nn.TransformerEncoderLayer(d_model, nhead, dim_feedforward,
                                                        dropout, batch_first=True)
        self.transformer_encoder = nn.TransformerEncoder(
            self.encoder_layer, num_layers, norm=nn.LayerNorm(d_model),
            enable_nested_tensor=False)

    def forward(self, V):
        tokens = self.embedding(V[..., None]) * math.sqrt(self.d_model)
        return self.transformer_encoder(tokens + self.pos_encoder.index(V.shape[1]))


class ReferenceTraONet(OperatorNet):
    """The authors' TraONet.

    Sensor tokens Linear(1, d)(V_j) · √d plus the sinusoidal encoding of the index j go
    through a post-norm ``nn.TransformerEncoder`` (ReLU) with a final LayerNorm. Query
    times go through :class:`~nh_operators.models._reference_layers.ReferenceTrunk`:
    tokens Linear(1, d)(t) · √d plus the encoding of t · 99/2 (the query's index on
    :data:`~nh_operators.TIMES`, as the reference encodes it), a post-norm decoder
    without masks and a final LayerNorm whose channels 0 and 1 are q and p (the
    reference's output layer ``fc`` is registered but never applied). The decoder's
    self-attention couples the query times (``query_coupled``).

    The registered but unused template layers (``branch_net.encoder_layer``,
    ``trunk_net.decoder_layer``) and ``trunk_net.fc`` are kept so that the authors'
    checkpoints load with ``strict=True``; they count as parameters (731,778 at the
    paper's size) and get no gradient.

    Args:
        d_model: token width d (paper: 64); even and divisible by ``nhead``.
        nhead: attention heads (paper: 8).
        num_layers: encoder layers and decoder layers each (paper: 3).
        dim_feedforward: feed-forward width (paper: 512).
        dropout: dropout of the transformer layers (training mode only; default 0).
        max_len: rows of the positional tables (100: the sensors and the grid).
        n_sensors: length m of V (default 100, at most ``max_len``).

    Input ``(V, t)``: V (B, m), t (M, 1); output (B, M, 2).

    Example:
        >>> import torch
        >>> net = ReferenceTraONet(d_model=8, nhead=2, num_layers=1, dim_feedforward=16)
        >>> net((torch.zeros(2, 100), torch.linspace(0, 2, 5)[:, None])).shape
        torch.Size([2, 5, 2])
    """

    query_coupled = True  # decoder self-attention over the query times

    def __init__(self, d_model=64, nhead=8, num_layers=3, dim_feedforward=512,
                 dropout=0.0, max_len=100, n_sensors=100):
        super().__init__()
        self.n_sensors = n_sensors
        self.branch_net = _TransformerBranch(d_model, nhead, num_layers, dim_feedforward,
                                             dropout, max_len)
        self.trunk_net = ReferenceTrunk(d_model, nhead, num_layers, dim_feedforward,
                                        dropout, max_len)

    def _forward(self, V, t):
        return self.trunk_net(t, self.branch_net(V))


class _MambaBranch(nn.Module):
    def __init__(self, d_model, num_layers, d_state, d_conv, expand):
        super().__init__()
        self.embedding = nn.Linear(1, d_model)
        self.mamba = nn.Module()
        self.mamba.layers = nn.ModuleList(
            ResidualBlock(d_model, Mamba(d_model, d_state=d_state, d_conv=d_conv,
                                         expand=expand, layer_idx=i, fp32_A=True))
            for i in range(num_layers))

    def forward(self, V):
        h = self.embedding(V[..., None])
        for layer in cast(nn.ModuleList, self.mamba.layers):
            h = layer(h)
        return h


class ReferenceMambONet(OperatorNet):
    """The authors' MambONet.

    Sensor values are embedded by Linear(1, d) (no √d, no positional encoding) and go
    through residual blocks x + Mamba(RMSNorm(x)) (no final norm); the result is the
    memory of the same trunk as :class:`ReferenceTraONet` (dropout 0), whose channels 0
    and 1 are q and p. The Mamba blocks are our
    :class:`~nh_operators.models.mamba.Mamba` (``mamba_ssm``'s parameter names, which
    the reference's pure-PyTorch Mamba shares), with A = −exp(A_log) taken in float32
    as the reference takes it. The decoder couples the query times (``query_coupled``).

    Args:
        d_model: token width d (paper: 128); even and divisible by ``nhead``.
        num_mamba_layers: Mamba blocks (the authors' ``num_layers1``; paper: 4).
        nhead: decoder attention heads (``n_head``; paper: 4).
        num_decoder_layers: decoder layers (``num_layers2``; paper: 4).
        dim_feedforward: decoder feed-forward width (``d_ff``; paper: 1024).
        d_state, d_conv, expand: Mamba's state size (16), convolution width (4) and
            expansion factor (2), the reference's values.
        max_len: rows of the decoder's positional table (100).
        n_sensors: length m of V (default 100).

    Input ``(V, t)``: V (B, m), t (M, 1); output (B, M, 2).

    Example:
        >>> import torch
        >>> net = ReferenceMambONet(d_model=8, num_mamba_layers=1, nhead=2,
        ...                         num_decoder_layers=1, dim_feedforward=16)
        >>> net((torch.zeros(2, 100), torch.linspace(0, 2, 5)[:, None])).shape
        torch.Size([2, 5, 2])
    """

    query_coupled = True  # decoder self-attention over the query times

    def __init__(self, d_model=128, num_mamba_layers=4, nhead=4, num_decoder_layers=4,
                 dim_feedforward=1024, d_state=16, d_conv=4, expand=2, max_len=100,
                 n_sensors=100):
        super().__init__()
        self.n_sensors = n_sensors
        self.encoder = _MambaBranch(d_model, num_mamba_layers, d_state, d_conv, expand)
        self.decoder = ReferenceTrunk(d_model, nhead, num_decoder_layers, dim_feedforward,
                                      0.0, max_len)

    def _forward(self, V, t):
        return self.decoder(t, self.encoder(V))
