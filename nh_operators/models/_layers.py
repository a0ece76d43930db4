"""Pieces shared by the networks: the DeepXDE base class, encodings, the time decoder."""

import math

import torch
from torch import nn

from .._backend import ensure_pytorch_backend

_dde = ensure_pytorch_backend()
NN = _dde.nn.pytorch.nn.NN

#: With ``scaled_outputs``, q = Q_MID + Q_HALF · y_q and p = P_MAX · y_p: q spans [0, 1],
#: and |p| ≤ sqrt(2 (V0 − min V)) ≤ sqrt(8) for the generator's V ≥ −2.
Q_MID, Q_HALF, P_MAX = 0.5, 0.5, math.sqrt(8.0)


def split_inputs(inputs, n_sensors, initial_state=False):
    """Check and unpack DeepXDE's ``(V, t)`` pair.

    Args:
        inputs: tuple ``(V, t)``: V of shape (B, n_sensors), t of shape (M, 1); with
            ``initial_state``, V is (B, n_sensors + 2): the sensors, then q0 and p0.
        n_sensors: the expected number of sensors.
        initial_state: whether the network reads a starting state after the sensors.

    Returns:
        (V, t) unchanged.

    Raises:
        ValueError: if the pair or a shape is wrong, naming the problem.
    """
    if not isinstance(inputs, (tuple, list)) or len(inputs) != 2:
        raise ValueError("a network input must be the pair (V, t) of DeepXDE's "
                         "TripleCartesianProd")
    V, t = inputs
    width = n_sensors + (2 if initial_state else 0)
    if V.ndim != 2 or V.shape[1] != width:
        what = (f" ({n_sensors} sensors, then q0 and p0: this network reads a starting "
                "state)" if initial_state else "")
        hint = ("; a network built with initial_state=True reads (q0, p0) after the sensors"
                if not initial_state and V.ndim == 2 and V.shape[1] == n_sensors + 2 else "")
        raise ValueError(f"V must have shape (batch, {width}){what}, got "
                         f"{tuple(V.shape)}{hint}")
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


class StateEmbedding(nn.Module):
    """(q0, p0) (B, 2) → one token (B, 1, d): how the sequence networks read a starting
    state (a Linear(2, d); the token joins the sensor tokens in front)."""

    def __init__(self, d_model):
        super().__init__()
        self.embed = nn.Linear(2, d_model)

    def forward(self, state):
        return self.embed(state)[:, None, :]


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

    def _attend(self, x, memory):
        return self.drop1(self.cross(x, memory, memory, need_weights=False)[0])

    def forward(self, x, memory):
        if self.norm_first:
            x = x + self._attend(self.norm1(x), memory)
            return x + self.drop2(self.ff(self.norm2(x)))
        x = self.norm1(x + self._attend(x, memory))
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
    """The trunk of TraONet and MambONet: time tokens attend to the encoded potential.

    Each query time t becomes Linear(1, d)(t) plus the sinusoidal encoding of the
    position t · ``time_scale`` (on the standard grid t_i = 2i/99 and the default
    scale 99/2 this is the index i, as in the paper; unlike an index it keeps its
    meaning for any set of query times). A transformer decoder without masks (every
    time token sees every other and the whole memory) is followed by Linear(d, n_out).

    With ``query_attention=True`` (the paper's decoder) the self-attention couples the
    query times: a prediction at t depends slightly on which other times are asked for
    in the same call. ``query_attention=False`` uses :class:`CrossDecoderLayer` (cross-
    attention and feed-forward only), so each time is predicted on its own.

    Args:
        d_model, nhead, num_layers, dim_feedforward, n_outputs, dropout, time_scale:
            as the networks that use it.
        query_attention: self-attention across the query times (default True).
        norm_first: pre-norm layers, plus a LayerNorm before the output layer.
        activation: "relu" (default, PyTorch's) or "gelu".
        scaled_outputs: False (default): the output layer predicts q and p themselves.
            True: it predicts y, and q = Q_MID + Q_HALF · y_q, p = P_MAX · y_p (needs
            ``n_outputs = 2``).

    Raises:
        ValueError: ``scaled_outputs`` with ``n_outputs`` other than 2.
    """

    def __init__(self, d_model, nhead, num_layers, dim_feedforward, n_outputs,
                 dropout=0.0, time_scale=99 / 2, query_attention=True, norm_first=False,
                 activation="relu", scaled_outputs=False):
        super().__init__()
        if scaled_outputs and n_outputs != 2:
            raise ValueError(f"scaled_outputs needs n_outputs = 2 (q and p), got {n_outputs}")
        self.scaled_outputs = bool(scaled_outputs)
        self.d_model = d_model
        self.time_scale = time_scale
        self.query_attention = query_attention
        self.embed = nn.Linear(1, d_model)
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
        """t (M, 1), memory (B, m, d) → (B, M, n_outputs); ``query_bias`` (B, 1, d), when
        given, is added to every time token of its row."""
        tokens = self.embed(t) + sinusoidal(t[:, 0] * self.time_scale, self.d_model)
        tokens = tokens.expand(memory.shape[0], -1, -1)
        if query_bias is not None:
            tokens = tokens + query_bias
        if self.query_attention:
            h = self.decoder(tokens, memory)
        else:
            h = tokens
            for layer in self.layers:
                h = layer(h, memory)
        if self.final_norm is not None:
            h = self.final_norm(h)
        y = self.head(h)
        if self.scaled_outputs:
            y = torch.stack([Q_MID + Q_HALF * y[..., 0], P_MAX * y[..., 1]], dim=-1)
        return y


class OperatorNet(NN):
    """Abstract base of our networks: input checks and DeepXDE's transforms.

    Subclasses implement ``_forward(V, t)`` → (B, M, n_outputs); with
    ``initial_state`` V holds the sensors then (q0, p0) (:meth:`_sensors_and_state`). DeepXDE's feature
    transform (``apply_feature_transform``) is applied to t, as in DeepXDE's own
    ``DeepONetCartesianProd``; its output transform gets ``((V, t), y)``. With
    ``n_outputs == 1`` the last axis is dropped, again as DeepXDE's DeepONet does.
    """

    n_sensors = 100
    n_outputs = 2
    #: True when the input V carries a starting state (q0, p0) after the sensors
    #: (constructor option ``initial_state``; False: release at rest at q = 0).
    initial_state = False
    #: True when a prediction at one time depends on the other times of the same call
    #: (self-attention over the query times, or an LSTM reading them as a sequence).
    query_coupled = False

    def forward(self, inputs):
        V, t = split_inputs(inputs, self.n_sensors, self.initial_state)
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

    def _state_modules(self, d_model, state_in_queries=False):
        """The state's embeddings of the sequence networks: one encoder token, and with
        ``state_in_queries`` a bias of every decoder time token."""
        if state_in_queries and not self.initial_state:
            raise ValueError("state_in_queries needs initial_state=True")
        self.state_in_queries = bool(state_in_queries)
        if self.initial_state:
            self.state_embedding = StateEmbedding(d_model)
        if self.state_in_queries:
            self.query_state = StateEmbedding(d_model)

    def _query_bias(self, state):
        return self.query_state(state) if getattr(self, "state_in_queries", False) else None

    def _sensors_and_state(self, V):
        """(sensors (B, m), state (B, 2) or None) of an input V."""
        if not self.initial_state:
            return V, None
        return V[:, :self.n_sensors], V[:, self.n_sensors:]
