"""The query decoder of TraONet and MambONet, its layers and the query encoding."""

import math
from typing import Sequence, Union

import torch
import torch.nn.functional as F
from torch import nn

from ._layers import P_MAX, Q_HALF, Q_MID, sinusoidal

__all__ = ["CrossDecoderLayer", "TimeDecoder", "attention_by_hand", "query_encoding",
           "transformer_encoder"]


def attention_by_hand(mha: nn.MultiheadAttention, x: torch.Tensor,
                      memory: torch.Tensor) -> torch.Tensor:
    """``mha(x, memory, memory)[0]`` written out: softmax(Q Kᵀ / √d_head) V per head.

    The fused CPU kernels of ``scaled_dot_product_attention`` (flash attention) have no
    double backward, so ``dde.grad.hessian``, or training on a first-order residual,
    fails through them; these ordinary operations have every derivative. Agrees with
    the fused kernel to rounding (about 1e-7 in float32); used only when a gradient of
    a gradient may be asked for, so the prediction path keeps its kernel and numbers.

    Args:
        mha: a batch-first ``nn.MultiheadAttention`` with biases and equal q, k, v
            widths (PyTorch's default layout).
        x: queries (B, M, d_model).
        memory: keys and values (B, m, d_model).

    Returns:
        Tensor (B, M, d_model).

    Example:
        >>> mha = nn.MultiheadAttention(8, 2, batch_first=True).eval()
        >>> x, mem = torch.rand(3, 5, 8), torch.rand(3, 4, 8)
        >>> bool((attention_by_hand(mha, x, mem) - mha(x, mem, mem)[0]).abs().max() < 1e-5)
        True
    """
    d, h = mha.embed_dim, mha.num_heads
    w, b = mha.in_proj_weight, mha.in_proj_bias
    (B, M, _), m = x.shape, memory.shape[1]
    q = F.linear(x, w[:d], b[:d]).view(B, M, h, d // h).transpose(1, 2)
    k = F.linear(memory, w[d:2 * d], b[d:2 * d]).view(B, m, h, d // h).transpose(1, 2)
    v = F.linear(memory, w[2 * d:], b[2 * d:]).view(B, m, h, d // h).transpose(1, 2)
    weights = torch.softmax(q @ k.transpose(-2, -1) * (d // h) ** -0.5, dim=-1)
    weights = F.dropout(weights, mha.dropout, mha.training)
    out = (weights @ v).transpose(1, 2).reshape(B, M, d)
    return F.linear(out, mha.out_proj.weight, mha.out_proj.bias)


def query_encoding(x: torch.Tensor, scales: Sequence[float], d_model: int) -> torch.Tensor:
    """Sinusoidal encoding of d-dimensional query points.

    The d_model / 2 frequencies 10000^(-2j/d_model), j = 0, 1, ..., are dealt to the
    coordinates in turn: frequency j encodes coordinate j mod d at the position
    x_k · scales[k] (sin in feature 2j, cos in 2j + 1), so every coordinate gets high
    and low frequencies. With d = 1 this is :func:`sinusoidal` of x · scale exactly.

    Args:
        x: query points (M, d).
        scales: d position scales, one per coordinate.
        d_model: even feature width, at least 2 d.

    Returns:
        Tensor (M, d_model).

    Raises:
        ValueError: if d_model is odd or below 2 d, or ``scales`` has not d entries.

    Example:
        >>> query_encoding(torch.zeros(5, 2), (1.0, 1.0), 8).shape
        torch.Size([5, 8])
    """
    d = x.shape[1]
    if len(scales) != d:
        raise ValueError(f"need one scale per query coordinate ({d}), got {len(scales)}")
    if d == 1:
        return sinusoidal(x[:, 0] * scales[0], d_model)
    if d_model % 2 or d_model < 2 * d:
        raise ValueError(f"d_model must be even and at least 2 × query_dim = {2 * d} to "
                         f"encode {d} query coordinates, got {d_model}")
    owner = torch.arange(d_model // 2, device=x.device) % d
    scale = torch.tensor(list(scales), dtype=x.dtype, device=x.device)
    j = torch.arange(0, d_model, 2, device=x.device, dtype=x.dtype)
    freq = torch.exp(-math.log(10000.0) * j / d_model)
    angle = (x * scale)[:, owner] * freq
    return torch.stack([torch.sin(angle), torch.cos(angle)], dim=-1).reshape(len(x), d_model)


class CrossDecoderLayer(nn.Module):
    """A transformer decoder layer without self-attention: each query token attends
    to the memory only, then goes through the feed-forward block, so every query is
    computed on its own (``nn.TransformerDecoderLayer`` minus its first block).

    Args:
        d_model, nhead, dim_feedforward, dropout: as ``nn.TransformerDecoderLayer``.
        activation: "relu" or "gelu".
        norm_first: pre-norm (x + f(LN(x))) instead of post-norm (LN(x + f(x))).
    """

    def __init__(self, d_model, nhead, dim_feedforward, dropout=0.0, activation="relu",
                 norm_first=False):
        super().__init__()
        self.norm_first = norm_first
        self.cross = nn.MultiheadAttention(d_model, nhead, dropout=dropout,
                                           batch_first=True)
        self.ff = nn.Sequential(nn.Linear(d_model, dim_feedforward), _activation(activation),
                                nn.Dropout(dropout), nn.Linear(dim_feedforward, d_model))
        self.norm1 = nn.LayerNorm(d_model)
        self.norm2 = nn.LayerNorm(d_model)
        self.drop1 = nn.Dropout(dropout)
        self.drop2 = nn.Dropout(dropout)

    def _attend(self, x, memory, twice_differentiable):
        if twice_differentiable:
            return self.drop1(attention_by_hand(self.cross, x, memory))
        return self.drop1(self.cross(x, memory, memory, need_weights=False)[0])

    def forward(self, x, memory, twice_differentiable: bool = False):
        """x (B, M, d), memory (B, m, d) → (B, M, d); ``twice_differentiable``: attend by
        :func:`attention_by_hand` (second derivatives) instead of the fused kernel."""
        if self.norm_first:
            x = x + self._attend(self.norm1(x), memory, twice_differentiable)
            return x + self.drop2(self.ff(self.norm2(x)))
        x = self.norm1(x + self._attend(x, memory, twice_differentiable))
        return self.norm2(x + self.drop2(self.ff(x)))


def _activation(name):
    if name not in ("relu", "gelu"):
        raise ValueError(f"activation must be 'relu' or 'gelu', got {name!r}")
    return nn.ReLU() if name == "relu" else nn.GELU()


def transformer_encoder(d_model, nhead, num_layers, dim_feedforward, dropout=0.0,
                        activation="relu", norm_first=False):
    """PyTorch's transformer encoder with our options (a final LayerNorm when pre-norm)."""
    _activation(activation)
    layer = nn.TransformerEncoderLayer(d_model, nhead, dim_feedforward, dropout,
                                       activation=activation, batch_first=True,
                                       norm_first=norm_first)
    return nn.TransformerEncoder(layer, num_layers, enable_nested_tensor=False,
                                 norm=nn.LayerNorm(d_model) if norm_first else None)


class TimeDecoder(nn.Module):
    """The trunk of TraONet and MambONet: query tokens attend to the encoded potential.

    A query point x = (x_1, ..., x_d) (for the paper's problem d = 1, the time t) becomes
    Linear(d, d_model)(x) plus :func:`query_encoding` of x: sinusoidal features at the
    positions x_k · ``time_scale[k]``, the frequencies dealt to the coordinates in turn.
    The scale sets the range: a position difference of 1 is one step of the finest
    frequency. On the standard grid t_i = 2i/99 the default scale 99/2 makes the
    position the index i, as in the paper (unlike an index it keeps its meaning for any
    query points); for a coordinate sampled at n points over a range L, L / (n − 1)
    apart, a good scale is (n − 1) / L. A transformer decoder without masks (every
    query token sees every other and the whole memory) is followed by Linear(d, n_out).

    With ``query_attention=True`` (the paper's decoder) the self-attention couples the
    query points: a prediction at x depends slightly on which other points are asked
    for in the same call. ``query_attention=False`` uses :class:`CrossDecoderLayer`
    (cross-attention and feed-forward only), so each point is predicted on its own, and
    its derivatives in x, first and second, are pointwise (when the query points require
    grad the attention is computed by :func:`attention_by_hand`, which has a double
    backward). The coupled decoder keeps PyTorch's fused attention, whose CPU kernel has
    no double backward: its second derivatives in x are not available there (nor
    pointwise anywhere).

    Args:
        d_model, nhead, num_layers, dim_feedforward, n_outputs, dropout: as the
            networks that use it.
        time_scale: the position scale, one float for every coordinate or d floats.
        query_attention: self-attention across the query points (default True).
        norm_first: pre-norm layers, plus a LayerNorm before the output layer.
        activation: "relu" (default, PyTorch's) or "gelu".
        scaled_outputs: False (default): the output layer predicts q and p themselves.
            True: it predicts y, and q = Q_MID + Q_HALF · y_q, p = P_MAX · y_p (needs
            ``n_outputs = 2``).
        query_dim: number d of coordinates of a query point (default 1).

    Raises:
        ValueError: ``scaled_outputs`` with ``n_outputs`` other than 2; a ``time_scale``
            sequence of the wrong length; ``d_model`` below 2 d.

    Example:
        >>> dec = TimeDecoder(8, 2, 1, 16, n_outputs=3, query_attention=False,
        ...                   time_scale=(10.0, 5.0), query_dim=2)
        >>> dec(torch.rand(7, 2), torch.zeros(4, 9, 8)).shape
        torch.Size([4, 7, 3])
    """

    def __init__(self, d_model, nhead, num_layers, dim_feedforward, n_outputs,
                 dropout=0.0, time_scale: Union[float, Sequence[float]] = 99 / 2,
                 query_attention=True, norm_first=False, activation="relu",
                 scaled_outputs=False, query_dim: int = 1):
        super().__init__()
        if scaled_outputs and n_outputs != 2:
            raise ValueError(f"scaled_outputs needs n_outputs = 2 (q and p), got {n_outputs}")
        if not isinstance(query_dim, int) or query_dim < 1:
            raise ValueError(f"query_dim must be a positive integer, got {query_dim!r}")
        scales = ((time_scale,) * query_dim if isinstance(time_scale, (int, float))
                  else tuple(float(s) for s in time_scale))
        query_encoding(torch.zeros(1, query_dim), scales, d_model)  # checks the sizes
        self.scaled_outputs = bool(scaled_outputs)
        self.d_model = d_model
        self.time_scale = time_scale
        self.scales = scales
        self.query_dim = query_dim
        self.query_attention = query_attention
        self.embed = nn.Linear(query_dim, d_model)
        if query_attention:
            _activation(activation)
            layer = nn.TransformerDecoderLayer(d_model, nhead, dim_feedforward, dropout,
                                               activation=activation, batch_first=True,
                                               norm_first=norm_first)
            self.decoder = nn.TransformerDecoder(layer, num_layers)
        else:
            self.layers = nn.ModuleList(
                CrossDecoderLayer(d_model, nhead, dim_feedforward, dropout, activation,
                                  norm_first) for _ in range(num_layers))
        self.final_norm = nn.LayerNorm(d_model) if norm_first else None
        self.head = nn.Linear(d_model, n_outputs)

    def forward(self, t, memory, query_bias=None):
        """t (M, d), memory (B, m, d_model) → (B, M, n_outputs); ``query_bias``
        (B, 1, d_model), when given, is added to every query token of its row."""
        tokens = self.embed(t) + query_encoding(t, self.scales, self.d_model)
        tokens = tokens.expand(memory.shape[0], -1, -1)
        if query_bias is not None:
            tokens = tokens + query_bias
        if self.query_attention:
            h = self.decoder(tokens, memory)
        else:
            # a derivative in the query points may be differentiated again (a hessian,
            # or training on a residual): attend by ordinary, twice-differentiable ops
            twice = torch.is_grad_enabled() and t.requires_grad
            h = tokens
            for layer in self.layers:
                h = layer(h, memory, twice)
        if self.final_norm is not None:
            h = self.final_norm(h)
        y = self.head(h)
        if self.scaled_outputs:
            y = torch.stack([Q_MID + Q_HALF * y[..., 0], P_MAX * y[..., 1]], dim=-1)
        return y
