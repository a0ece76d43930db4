"""Pieces shared by the networks: the DeepXDE base class, input checks, dtypes, encodings."""

import math
import warnings
from typing import Any, Optional

import torch
from torch import nn

from .._backend import ensure_pytorch_backend

_dde: Any = ensure_pytorch_backend()  # deepxde ships no type information
NN = _dde.nn.pytorch.nn.NN

#: With ``scaled_outputs``, q = Q_MID + Q_HALF · y_q and p = P_MAX · y_p: q spans [0, 1],
#: and |p| ≤ sqrt(2 (V0 − min V)) ≤ sqrt(8) for the generator's V ≥ −2.
Q_MID, Q_HALF, P_MAX = 0.5, 0.5, math.sqrt(8.0)


def split_inputs(inputs, n_sensors, initial_state=False, query_dim=1):
    """Check and unpack DeepXDE's ``(V, t)`` pair.

    Args:
        inputs: tuple ``(V, t)``: V of shape (B, n_sensors), t of shape (M, query_dim);
            with ``initial_state``, V is (B, n_sensors + 2): the sensors, then q0 and p0.
        n_sensors: the expected number of sensors.
        initial_state: whether the network reads a starting state after the sensors.
        query_dim: the number d of coordinates of a query point (1 for time alone).

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
    if t.ndim != 2 or t.shape[1] != query_dim:
        hint = (f"; build the network with query_dim={t.shape[1]} for {t.shape[1]}-D "
                "query points" if t.ndim == 2 and t.shape[1] != query_dim else "")
        raise ValueError(f"query points must have shape (M, {query_dim}), got "
                         f"{tuple(t.shape)}{hint}")
    return V, t


#: Real dtype → complex dtype of the same precision (FNO's spectral weights).
_COMPLEX_OF = {torch.float16: torch.complex32, torch.float32: torch.complex64,
               torch.float64: torch.complex128}


def cast_module(net: nn.Module, dtype: torch.dtype) -> nn.Module:
    """Cast a module's real floating tensors to ``dtype`` and its complex ones to the
    complex dtype of the same precision, in place (``Module.to(dtype)`` would drop the
    imaginary part of complex weights). Integer tensors are left alone.

    Args:
        net: a ``torch.nn.Module``.
        dtype: ``torch.float16``, ``torch.float32`` or ``torch.float64``.

    Returns:
        The same module.

    Raises:
        ValueError: for any other dtype.

    Example:
        >>> cast_module(nn.Linear(2, 3), torch.float64).weight.dtype
        torch.float64
    """
    if dtype not in _COMPLEX_OF:
        raise ValueError("dtype must be torch.float16, torch.float32 or torch.float64, "
                         f"got {dtype}")

    def cast(t: torch.Tensor) -> torch.Tensor:
        if t.is_complex():
            return t if t.dtype == _COMPLEX_OF[dtype] else t.to(_COMPLEX_OF[dtype])
        if t.is_floating_point() and t.dtype != dtype:
            return t.to(dtype)
        return t

    return net._apply(cast)


def match_default_float(net: nn.Module) -> nn.Module:
    """Cast a freshly built network to DeepXDE's default float, as DeepXDE's own
    networks are built (``dde.config.real(torch)``; complex weights to the matching
    complex dtype). Call it at the end of a network's ``__init__``.

    With DeepXDE's default float32 and a network already in float32 nothing changes
    (the same tensors are kept). After ``dde.config.set_default_float("float64")`` every
    real parameter and buffer becomes float64 and every complex one complex128.

    Args:
        net: the network (any ``torch.nn.Module``).

    Returns:
        The same network, cast in place.

    Example:
        >>> net = match_default_float(nn.Linear(2, 3))
        >>> net.weight.dtype == _dde.config.real(torch)
        True
    """
    return cast_module(net, _dde.config.real(torch))


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


def resolve_query_coupled(query_coupled: Optional[bool], query_attention: Optional[bool],
                          default: bool = True) -> bool:
    """The coupling switch of a network that also takes the older spelling.

    ``query_coupled`` is the name every network takes; TraONet and MambONet also accept
    ``query_attention`` (self-attention across the query points), which shipped
    ``config.json`` files contain.

    Args:
        query_coupled: the switch, or None.
        query_attention: the older spelling, or None.
        default: the value when neither is given.

    Returns:
        Whether the network couples its query points.

    Raises:
        ValueError: if both are given and disagree.

    Example:
        >>> resolve_query_coupled(None, False)
        False
    """
    if query_coupled is not None and query_attention is not None \
            and bool(query_coupled) != bool(query_attention):
        raise ValueError(f"query_coupled={query_coupled} and query_attention="
                         f"{query_attention} disagree; query_attention is the older name "
                         "of query_coupled: give one of them")
    for value in (query_coupled, query_attention):
        if value is not None:
            return bool(value)
    return default


class OperatorNet(NN):
    """Abstract base of our networks: input checks and DeepXDE's transforms.

    Subclasses implement ``_forward(V, t)`` → (B, M, n_outputs), t the (M, query_dim)
    query points; with ``initial_state`` V holds the sensors then (q0, p0)
    (:meth:`_sensors_and_state`). DeepXDE's feature transform
    (``apply_feature_transform``) is applied to t, as in DeepXDE's own
    ``DeepONetCartesianProd``; its output transform gets ``((V, t), y)``. With
    ``n_outputs == 1`` the last axis is dropped, again as DeepXDE's DeepONet does.
    Subclasses set ``regularizer`` (DeepXDE's ``regularization=``) and end their
    ``__init__`` with :func:`match_default_float`.

    A query-coupled network (``query_coupled``) warns once when a derivative with
    respect to its query points is taken with its graph kept (``dde.grad``'s way, for
    a PDE residual): such derivatives are not pointwise.
    """

    n_sensors = 100
    n_outputs = 2
    #: True when the input V carries a starting state (q0, p0) after the sensors
    #: (constructor option ``initial_state``; False: release at rest at q = 0).
    initial_state = False
    #: True when a prediction at one time depends on the other times of the same call
    #: (self-attention over the query times, or an LSTM reading them as a sequence).
    query_coupled = False
    #: Number d of coordinates of a query point: the trunk input is (M, d).
    query_dim = 1

    def forward(self, inputs):
        V, t = split_inputs(inputs, self.n_sensors, self.initial_state, self.query_dim)
        if self._input_transform is not None:
            t = self._input_transform(t)
        if self.query_coupled and torch.is_grad_enabled() and t.requires_grad:
            t = self._watch_query_derivatives(t)
        y = self._forward(V, t)
        if self.n_outputs == 1:
            y = y[..., 0]
        if self._output_transform is not None:
            y = self._output_transform(inputs, y)
        return y

    def _forward(self, V, t):  # pragma: no cover - abstract
        raise NotImplementedError

    def _watch_query_derivatives(self, t: torch.Tensor) -> torch.Tensor:
        """Warn (once per network) when a derivative with respect to the query points
        that keeps its graph, as ``dde.grad.jacobian``/``hessian`` take it for a PDE
        residual, reaches them: a query-coupled network's is not pointwise. A plain
        ``loss.backward()`` (data-driven training, where DeepXDE also marks the query
        points as requiring grad) does not warn."""
        if getattr(self, "_warned_query_derivatives", False):
            return t
        t = t.view_as(t)  # a fresh node per call, so hooks never pile up on a leaf

        def hook(grad: torch.Tensor) -> None:
            if grad.requires_grad and not self._warned_query_derivatives:
                self._warned_query_derivatives = True
                warnings.warn(
                    f"{type(self).__name__} couples its query points (query_coupled=True): "
                    "its derivatives with respect to them (dde.grad.jacobian / hessian) are "
                    "not pointwise, so a PDE residual built from them is not the PDE's; "
                    "build it with query_coupled=False for physics-informed training",
                    UserWarning, stacklevel=2)

        self._warned_query_derivatives = False
        t.register_hook(hook)
        return t

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
