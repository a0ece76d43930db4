"""Pieces of the authors' networks (reference code at 5c4cbd8), under their module names.

The reference variants (:mod:`~nh_operators.models.reference`) are built from these so
that their ``state_dict`` keys are the authors' own: the positional table ``pe``, the
RMSNorm of the Mamba blocks, and the transformer trunk shared by TraONet and MambONet.
"""

import math

import torch
from torch import nn

__all__ = ["PositionalEncoding", "RMSNorm", "ReferenceTrunk", "ResidualBlock",
           "reference_encoding"]

#: |position − nearest index| below which a query position reads the stored table.
_ON_INDEX = 1e-4


def reference_encoding(position, d_model):
    """The reference's sinusoidal encoding, in its own float32 arithmetic.

    Args:
        position: tensor (n,) of (possibly fractional) positions.
        d_model: even width d.

    Returns:
        float32 tensor (n, d): sin(pos · w_j) in even, cos(pos · w_j) in odd features,
        w_j = exp(2j · (−ln 10⁴ / d)), computed as the reference computes its table.
    """
    if d_model % 2:
        raise ValueError(f"d_model must be even for the sinusoidal encoding, got {d_model}")
    pos = position.detach().to(torch.float32)[:, None]
    div = torch.exp(torch.arange(0, d_model, 2, dtype=torch.float32, device=pos.device)
                    * (-math.log(10000.0) / d_model))
    out = torch.zeros(pos.shape[0], d_model, dtype=torch.float32, device=pos.device)
    out[:, 0::2] = torch.sin(pos * div)
    out[:, 1::2] = torch.cos(pos * div)
    return out


class PositionalEncoding(nn.Module):
    """The reference's positional table: buffer ``pe`` of shape (1, max_len, d).

    The table is computed in float32 (as the reference computes it) and cast with the
    module, so it holds exactly the authors' numbers in any dtype.
    """

    pe: torch.Tensor  # the registered buffer

    def __init__(self, d_model, max_len=100):
        super().__init__()
        self.d_model = d_model
        self.register_buffer("pe", reference_encoding(torch.arange(max_len), d_model)[None])

    def index(self, n):
        """Rows 0..n−1 of the table, (n, d): the encoding by index."""
        if n > self.pe.shape[1]:
            raise ValueError(f"the positional table has {self.pe.shape[1]} rows, "
                             f"asked for {n}")
        return self.pe[0, :n]

    def at(self, position):
        """Encoding at positions (n,) → (n, d).

        A position within 1e-4 of an index of the table reads that row (so on the
        standard grid this is exactly the reference's index encoding); any other
        position gets the same formula, evaluated in the same float32 arithmetic.
        """
        pe = self.pe[0]
        nearest = torch.round(position.detach())
        on = ((position.detach() - nearest).abs() <= _ON_INDEX) & (nearest >= 0) & (
            nearest < pe.shape[0])
        if bool(on.all()):
            return pe[nearest.long()]
        out = reference_encoding(position, self.d_model).to(pe.dtype)
        out[on] = pe[nearest[on].long()]
        return out


class RMSNorm(nn.Module):
    """x · rsqrt(mean(x²) + eps) · weight over the last axis (the reference's Mamba
    blocks; eps 1e-5)."""

    def __init__(self, d_model, eps=1e-5):
        super().__init__()
        self.eps = eps
        self.weight = nn.Parameter(torch.ones(d_model))

    def forward(self, x):
        return x * torch.rsqrt(x.pow(2).mean(-1, keepdim=True) + self.eps) * self.weight


class ResidualBlock(nn.Module):
    """x + mixer(RMSNorm(x)), ``mixer`` a Mamba block."""

    def __init__(self, d_model, mixer):
        super().__init__()
        self.mixer = mixer
        self.norm = RMSNorm(d_model)

    def forward(self, x):
        return x + self.mixer(self.norm(x))


class ReferenceTrunk(nn.Module):
    """The reference's transformer trunk (TraONet's ``trunk_net``, MambONet's ``decoder``).

    A time t becomes Linear(1, d)(t) · √d plus the table's encoding at the position
    t · ``time_scale`` (on the grid t_i = 2i/99 with the default 99/2: the index i, as
    the reference encodes its queries). A post-norm ``nn.TransformerDecoder`` without
    masks and with a final LayerNorm follows; q and p are channels 0 and 1 of that
    LayerNorm. The output layer ``fc`` and the template ``decoder_layer`` are kept (the
    reference registers them, so its checkpoints hold them) but never applied.

    Self-attention runs across the query times, so they are coupled.
    """

    def __init__(self, d_model, nhead, num_layers, dim_feedforward, dropout=0.0,
                 max_len=100, time_scale=99 / 2):
        super().__init__()
        self.d_model = d_model
        self.time_scale = time_scale
        self.embedding = nn.Linear(1, d_model)
        self.pos_encoder = PositionalEncoding(d_model, max_len)
        self.decoder_layer = nn.TransformerDecoderLayer(d_model, nhead, dim_feedforward,
                                                        dropout, batch_first=True)
        self.transformer_decoder = nn.TransformerDecoder(self.decoder_layer, num_layers,
                                                         norm=nn.LayerNorm(d_model))
        self.fc = nn.Linear(d_model, 2)

    def forward(self, t, memory):
        """t (M, 1), memory (B, m, d) → (B, M, 2)."""
        tokens = self.embedding(t) * math.sqrt(self.d_model)
        tokens = tokens + self.pos_encoder.at(t[:, 0] * self.time_scale)
        tokens = tokens.expand(memory.shape[0], -1, -1)
        return self.transformer_decoder(tokens, memory)[..., :2]
