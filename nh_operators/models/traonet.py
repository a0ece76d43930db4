"""TraONet: a transformer encoder over the potential, a transformer decoder over time."""

from typing import Optional, Sequence, Union

import torch

from ._decoder import TimeDecoder, transformer_encoder
from ._layers import OperatorNet, SensorEmbedding, match_default_float, resolve_query_coupled

__all__ = ["TraONet"]


class TraONet(OperatorNet):
    """Transformer operator network (the paper's §2.3).

    Each sensor value V(x_j) is embedded by a shared Linear(1, d) plus the sinusoidal
    encoding of its index; a transformer encoder turns these tokens into a memory
    (B, m, d). Query points go through the time decoder
    (embedding, sinusoidal encoding of the query coordinates, transformer decoder without
    masks, and an output layer to the outputs — the layer the reference code skipped).

    **Query points.** A query point x of d = ``query_dim`` coordinates (the time t for
    the paper's problem) is embedded as Linear(d, d_model)(x) plus sinusoidal features:
    the d_model / 2 frequencies 10000^(-2j/d_model) are dealt to the coordinates in turn
    (j ↦ coordinate j mod d), each at the position x_k · ``time_scale[k]``. The scale sets
    the resolution: the finest frequency turns by one radian per unit of position, so a
    good scale is about (points per coordinate − 1) / (its range), e.g. 99/2 for 100
    times on [0, 2] (the default, where the position is the grid index), 63 for 64 points
    on [0, 1]. The coordinates are not otherwise rescaled: keep them of order 1.

    Args:
        d_model: token width d (paper: 64). Must be even and divisible by ``nhead``.
        nhead: attention heads (paper: 8).
        num_layers: encoder layers and decoder layers each (paper: 3).
        dim_feedforward: width of the feed-forward blocks (paper: 512).
        dropout: dropout in the transformer layers (default 0: a regression).
        n_sensors: length m of V (default 100).
        n_outputs: outputs per time (2: q and p; 1 gives shape (B, M)).
        time_scale: positions of the query encoding are x_k · time_scale (default 99/2:
            the index on the standard grid t_i = 2i/99); one float, or d floats.
        query_coupled: self-attention across the query points in the decoder (default
            True, the paper's). False: each point is predicted on its own by cross-
            attention to the memory alone, and ``dde.grad.jacobian``/``hessian`` give
            its pointwise first and second derivatives (physics-informed training).
        query_attention: the older name of ``query_coupled`` (shipped configs use it);
            giving both with different values is a ValueError.
        norm_first: pre-norm transformer layers (default False: post-norm, PyTorch's).
        activation: "relu" (default) or "gelu" in the feed-forward blocks.
        scaled_outputs: False (default): the output layer predicts q and p themselves.
            True: it predicts (2q − 1, p / sqrt(8)), both within [−1, 1], and the network
            maps them back, so the loss and the outputs are unchanged in meaning.
        initial_state: False (default): release at rest at q = 0, the paper's scene.
            True: V carries (q0, p0) after the sensors, (B, m + 2), embedded as one
            more encoder token (Linear(2, d), no position) in front of the sensors.
        state_in_queries: with ``initial_state``, also add a second Linear(2, d) of the
            state to every time token of the decoder, so each query reads the state
            directly (default False).
        query_dim: number d of coordinates of a query point (default 1: the time).
        regularization: DeepXDE's regularizer, e.g. ``("l2", 1e-5)``, read by
            ``dde.Model.compile`` from ``net.regularizer`` (default None).

    Input ``(V, x)``: V (B, m), x (M, d); output (B, M, n_outputs), or (B, M) for one
    output. Built in DeepXDE's default float (``dde.config.real(torch)``).

    Raises:
        ValueError: for inconsistent options (see above), ``d_model`` below 2 d.

    References:
        A. Vaswani et al., "Attention is all you need", NeurIPS (2017).
        T.-G. Kim and S. C. Park, "Neural Hamilton: Can A.I. Understand Hamiltonian
        Mechanics?" (2024), §2.3.

    Example:
        >>> import torch
        >>> net = TraONet(d_model=16, nhead=2, num_layers=1, dim_feedforward=32)
        >>> net((torch.zeros(3, 100), torch.linspace(0, 2, 7)[:, None])).shape
        torch.Size([3, 7, 2])
    """

    query_coupled = True  # decoder self-attention over the query points (by default)

    def __init__(self, d_model: int = 64, nhead: int = 8, num_layers: int = 3,
                 dim_feedforward: int = 512, dropout: float = 0.0, n_sensors: int = 100,
                 n_outputs: int = 2, time_scale: Union[float, Sequence[float]] = 99 / 2,
                 query_attention: Optional[bool] = None, norm_first: bool = False,
                 activation: str = "relu", scaled_outputs: bool = False,
                 initial_state: bool = False, state_in_queries: bool = False,
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
        self.embedding = SensorEmbedding(d_model, positional=True)
        self.encoder = transformer_encoder(d_model, nhead, num_layers, dim_feedforward,
                                           dropout, activation, norm_first)
        self.decoder = TimeDecoder(d_model, nhead, num_layers, dim_feedforward,
                                   n_outputs, dropout, time_scale, query_attention,
                                   norm_first, activation, scaled_outputs, query_dim)
        self.scaled_outputs = self.decoder.scaled_outputs
        match_default_float(self)

    def _forward(self, V, t):
        V, state = self._sensors_and_state(V)
        tokens = self.embedding(V)
        if state is not None:
            tokens = torch.cat([self.state_embedding(state), tokens], dim=1)
        return self.decoder(t, self.encoder(tokens), self._query_bias(state))
