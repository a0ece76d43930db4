"""TraONet: a transformer encoder over the potential, a transformer decoder over time."""

import torch

from ._layers import OperatorNet, SensorEmbedding, TimeDecoder, transformer_encoder

__all__ = ["TraONet"]


class TraONet(OperatorNet):
    """Transformer operator network (the paper's §2.3).

    Each sensor value V(x_j) is embedded by a shared Linear(1, d) plus the sinusoidal
    encoding of its index; a transformer encoder turns these tokens into a memory
    (B, m, d). Query times go through :class:`~nh_operators.models._layers.TimeDecoder`
    (embedding, sinusoidal encoding of t, transformer decoder without masks, and an
    output layer to (q, p) — the layer the reference code skipped).

    Args:
        d_model: token width d (paper: 64). Must be even and divisible by ``nhead``.
        nhead: attention heads (paper: 8).
        num_layers: encoder layers and decoder layers each (paper: 3).
        dim_feedforward: width of the feed-forward blocks (paper: 512).
        dropout: dropout in the transformer layers (default 0: a regression).
        n_sensors: length m of V (default 100).
        n_outputs: outputs per time (2: q and p; 1 gives shape (B, M)).
        time_scale: positions of the time encoding are t · time_scale (default 99/2:
            the index on the standard grid t_i = 2i/99).
        query_attention: self-attention across the query times in the decoder
            (default True, the paper's). False: each time is predicted on its own, and
            ``query_coupled`` is False.
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

    Input ``(V, t)``: V (B, m), t (M, 1); output (B, M, n_outputs).

    Example:
        >>> import torch
        >>> net = TraONet(d_model=16, nhead=2, num_layers=1, dim_feedforward=32)
        >>> net((torch.zeros(3, 100), torch.linspace(0, 2, 7)[:, None])).shape
        torch.Size([3, 7, 2])
    """

    query_coupled = True  # decoder self-attention over the query times (by default)

    def __init__(self, d_model=64, nhead=8, num_layers=3, dim_feedforward=512,
                 dropout=0.0, n_sensors=100, n_outputs=2, time_scale=99 / 2,
                 query_attention=True, norm_first=False, activation="relu",
                 scaled_outputs=False, initial_state=False, state_in_queries=False):
        super().__init__()
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
                                   norm_first, activation, scaled_outputs)
        self.scaled_outputs = self.decoder.scaled_outputs

    def _forward(self, V, t):
        V, state = self._sensors_and_state(V)
        tokens = self.embedding(V)
        if state is not None:
            tokens = torch.cat([self.state_embedding(state), tokens], dim=1)
        return self.decoder(t, self.encoder(tokens), self._query_bias(state))
