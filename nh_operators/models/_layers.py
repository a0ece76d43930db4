"""Pieces shared by the networks: the DeepXDE base class, encodings, the time decoder."""

import math

import torch
from torch import nn

from .._backend import ensure_pytorch_backend

_dde = ensure_pytorch_backend()
NN = _dde.nn.pytorch.nn.NN


def split_inputs(inputs, n_sensors):
    """Check and unpack DeepXDE's ``(V, t)`` pair.

    Args:
        inputs: tuple ``(V, t)``: V of shape (B, n_sensors), t of shape (M, 1).
        n_sensors: the expected number of sensors.

    Returns:
        (V, t) unchanged.

    Raises:
        ValueError: if the pair or a shape is wrong, naming the problem.
    """
    if not isinstance(inputs, (tuple, list)) or len(inputs) != 2:
        raise ValueError("a network input must be the pair (V, t) of DeepXDE's "
                         "TripleCartesianProd")
    V, t = inputs
    if V.ndim != 2 or V.shape[1] != n_sensors:
        raise ValueError(f"V must have shape (batch, {n_sensors}), got {tuple(V.shape)}")
    if t.ndim != 2 or t.shape[1] != 1:
        raise ValueError(f"t must have shape (M, 1), got {tuple(t.shape)}")
    return V, t


def sinusoidal(position, d_model):
    """Sinusoidal encoding of (possibly fractional) positions.

    Args:
        position: tensor of shape (..., n).
        d_model: even feature width d.

    Returns:
        Tensor (..., n, d): sin(pos / 10000^(2j/d)) in even, cos in odd features.
    """
    if d_model % 2:
        raise ValueError(f"d_model must be even for the sinusoidal encoding, got {d_model}")
    j = torch.arange(0, d_model, 2, device=position.device, dtype=position.dtype)
    freq = torch.exp(-math.log(10000.0) * j / d_model)
    angle = position[..., None] * freq
    out = torch.empty(*angle.shape[:-1], d_model, device=position.device,
                      dtype=position.dtype)
    out[..., 0::2] = torch.sin(angle)
    out[..., 1::2] = torch.cos(angle)
    return out


class SensorEmbedding(nn.Module):
    """V (B, m) → tokens (B, m, d): a shared Linear(1, d), plus the sensor index's
    sinusoidal encoding when ``positional``."""

    def __init__(self, d_model, positional=True):
        super().__init__()
        self.d_model = d_model
        self.positional = positional
        self.embed = nn.Linear(1, d_model)

    def forward(self, V):
        tokens = self.embed(V[..., None])
        if self.positional:
            index = torch.arange(V.shape[1], device=V.device, dtype=V.dtype)
            tokens = tokens + sinusoidal(index, self.d_model)
        return tokens


class TimeDecoder(nn.Module):
    """The trunk of TraONet and MambONet: time tokens attend to the encoded potential.

    Each query time t becomes Linear(1, d)(t) plus the sinusoidal encoding of the
    position t · ``time_scale`` (on the standard grid t_i = 2i/99 and the default
    scale 99/2 this is the index i, as in the paper; unlike an index it keeps its
    meaning for any set of query times). A transformer decoder without masks (every
    time token sees every other and the whole memory) is followed by Linear(d, n_out).

    Note that the self-attention couples the query times: a prediction at t depends
    slightly on which other times are asked for in the same call.
    """

    def __init__(self, d_model, nhead, num_layers, dim_feedforward, n_outputs,
                 dropout=0.0, time_scale=99 / 2):
        super().__init__()
        self.d_model = d_model
        self.time_scale = time_scale
        self.embed = nn.Linear(1, d_model)
        layer = nn.TransformerDecoderLayer(d_model, nhead, dim_feedforward, dropout,
                                           batch_first=True)
        self.decoder = nn.TransformerDecoder(layer, num_layers)
        self.head = nn.Linear(d_model, n_outputs)

    def forward(self, t, memory):
        """t (M, 1), memory (B, m, d) → (B, M, n_outputs)."""
        tokens = self.embed(t) + sinusoidal(t[:, 0] * self.time_scale, self.d_model)
        tokens = tokens.expand(memory.shape[0], -1, -1)
        return self.head(self.decoder(tokens, memory))


class OperatorNet(NN):
    """Abstract base of our networks: input checks and DeepXDE's transforms.

    Subclasses implement ``_forward(V, t)`` → (B, M, n_outputs). DeepXDE's feature
    transform (``apply_feature_transform``) is applied to t, as in DeepXDE's own
    ``DeepONetCartesianProd``; its output transform gets ``((V, t), y)``. With
    ``n_outputs == 1`` the last axis is dropped, again as DeepXDE's DeepONet does.
    """

    n_sensors = 100
    n_outputs = 2
    #: True when a prediction at one time depends on the other times of the same call
    #: (self-attention over the query times, or an LSTM reading them as a sequence).
    query_coupled = False

    def forward(self, inputs):
        V, t = split_inputs(inputs, self.n_sensors)
        if self._input_transform is not None:
            t = self._input_transform(t)
        y = self._forward(V, t)
        if self.n_outputs == 1:
            y = y[..., 0]
        if self._output_transform is not None:
            y = self._output_transform(inputs, y)
        return y

    def _forward(self, V, t):  # pragma: no cover - abstract
        raise NotImplementedError
