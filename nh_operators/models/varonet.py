"""VaRONet: an LSTM encoder, a Gaussian latent, and LSTM decoders for q and p."""

from __future__ import annotations

from collections.abc import Sequence
from typing import cast

import numpy as np
import torch
from torch import nn

from ._layers import OperatorNet, match_default_float
from .readout import GridSpline, as_ranges

__all__ = ["VaRONet"]


class VaRONet(OperatorNet):
    """Variational recurrent operator network (the paper's §2.2).

    An LSTM reads V(x_1), ..., V(x_m); its last hidden state h gives μ = F_μ(h) and
    log σ² = F_σ(h). In training z = μ + σ ⊙ ε with ε ~ N(0, I) (the
    reparameterisation trick); in eval mode z = μ, so predictions are deterministic.
    Linear maps of z give the initial hidden and cell states of one LSTM decoder per
    output, which reads query coordinates and emits its output through a Linear(H, 1)
    head.

    After every forward, ``self.kl`` holds the batch mean of
    KL(N(μ, σ²) ‖ N(0, I)) = −½ Σ (1 + log σ² − μ² − σ²); the training data object
    adds β · kl / (k M) to DeepXDE's mean-squared data loss as its own column (the
    paper's loss Σ (error²) + β · KL per sample divided by its k M outputs):
    :class:`nh_operators.OperatorData` does it for our problem, and
    :class:`~nh_operators.models.KLData` wraps any DeepXDE data object
    (``TripleCartesianProd``, ``PDEOperatorCartesianProd``) to do the same.

    **The encoder's cell states** (``encoder_cell=True``). The reference code that
    produced the paper's tables starts each decoder from h = a map of z and
    c = the encoder's final cell states, layer by layer: a deterministic path of
    ``num_layers * hidden_size`` numbers beside the latent, which the KL term does not
    constrain. The paper's text describes only the latent. With the default
    (``False``), both h and c come from z, and the latent is the only path; the KL term
    then trades precision for nats (docs/recipe.md measures what the option changes).

    **Query points and their scaling.** Query points are DeepXDE's (M, d) tensor.
    Coordinate j, with range ``query_range[j] = (lo, hi)``, enters the decoders as
    2 (x_j − lo) / (hi − lo), so every range is mapped onto [0, 2], the paper's time
    range (with the default range (0, 2) the times enter unchanged). How the decoders
    read the points:

    * d = 1, ``query_coupled=False`` (default, pointwise): the decoders read a fixed
      grid of ``n_grid`` uniform points of the range (by default
      :data:`~nh_operators.TIMES`) as their sequence, and the asked points are read off
      the grid outputs by the not-a-knot cubic spline
      (:class:`~nh_operators.models.readout.GridSpline`): a prediction at x does not
      depend on the other points asked, and it is twice differentiable in x
      (``dde.grad.hessian`` gives the spline's second derivative). Points must lie in
      the range. On the grid itself, when the points need no gradient, the grid
      outputs are returned as they are.
    * d > 1, ``query_coupled=False``: each point is decoded on its own as a short
      sequence of d steps, step j reading the scaled coordinate j, from the initial
      states given by z; the last step's output is the prediction (smooth in every
      coordinate, so twice differentiable; points outside the range extrapolate).
    * ``query_coupled=True``: the decoders read the asked points, in the order given,
      as one sequence of M steps of d scaled coordinates, as the paper describes for
      times: a prediction then changes with the other points asked.

    Args:
        hidden_size: LSTM width H (paper: 512).
        num_layers: layers of every LSTM (paper: 4).
        latent_dim: size of z (paper: 30).
        n_sensors: length m of V (default 100).
        n_outputs: outputs k, one decoder each: 2 for (q, p) (1 gives shape (B, M)).
        encoder_cell: start the decoders' cell states from the encoder's (see above).
        grid_decoder: the older spelling of ``not query_coupled`` (kept for saved
            configs); None: not given.
        initial_state: True: V carries (q0, p0) after the sensors, (B, m + 2), and the
            encoder reads (V(x_j), q0, p0) at every step (default False: rest at
            q = 0).
        query_coupled: see above (default False; None: not given).
        query_dim: number d of coordinates of a query point (default 1, the time).
        query_range: (lo, hi) of every coordinate, or d such pairs (default (0, 2)).
        n_grid: points of the decoders' grid for d = 1 (default 100; a good value
            resolves the outputs' finest feature with a few points).
        regularization: DeepXDE's regularizer, e.g. ``["l2", 1e-5]`` (as its own
            networks take it; ``dde.Model.compile`` reads ``net.regularizer``).

    Raises:
        ValueError: if ``grid_decoder`` and ``query_coupled`` disagree, or for a bad
            range or size.

    Attributes:
        noise: ``None`` (ε = ``torch.randn_like(μ)``) or a callable ``noise(mu)``
            returning ε of μ's shape; a distributed run sets it to
            :meth:`~nh_operators.data.ShardedOperatorData.batch_noise`, which draws the
            global batch's noise and slices this rank's rows, so N processes draw what
            one would.

    Input ``(V, x)``: V (B, m), x (M, d); output (B, M, n_outputs). With
    ``query_coupled=True`` and times, ask for them in increasing order. The network is
    built in DeepXDE's default float (``dde.config.set_default_float``).

    References:
        D. P. Kingma and M. Welling, "Auto-encoding variational Bayes", ICLR (2014);
        S. Hochreiter and J. Schmidhuber, "Long short-term memory", Neural Computation 9
        (1997). T.-G. Kim and S. C. Park, "Neural Hamilton: Can A.I. Understand Hamiltonian
        Mechanics?" (2024), §2.2.

    Example:
        >>> import torch
        >>> net = VaRONet(hidden_size=8, num_layers=1, latent_dim=4).eval()
        >>> y = net((torch.zeros(3, 100), torch.linspace(0, 2, 6)[:, None]))
        >>> y.shape, net.kl.shape
        (torch.Size([3, 6, 2]), torch.Size([]))
    """

    def __init__(self, hidden_size: int = 512, num_layers: int = 4, latent_dim: int = 30,
                 n_sensors: int = 100, n_outputs: int = 2, encoder_cell: bool = False,
                 grid_decoder: bool | None = None, initial_state: bool = False,
                 query_coupled: bool | None = None, query_dim: int = 1,
                 query_range: Sequence = (0.0, 2.0), n_grid: int = 100,
                 regularization: list | None = None) -> None:
        super().__init__()
        if grid_decoder is not None and query_coupled is not None \
                and bool(grid_decoder) == bool(query_coupled):
            raise ValueError(f"grid_decoder={grid_decoder} and query_coupled={query_coupled} "
                             "disagree: grid_decoder is the older spelling of "
                             "not query_coupled; give one of them")
        if query_coupled is None:
            query_coupled = False if grid_decoder is None else not grid_decoder
        for name, value, least in (("n_sensors", n_sensors, 1), ("n_outputs", n_outputs, 1),
                                   ("query_dim", query_dim, 1), ("n_grid", n_grid, 2)):
            if int(value) < least:
                raise ValueError(f"{name} must be at least {least}, got {value}")
        self.query_coupled = bool(query_coupled)
        self.grid_decoder = not self.query_coupled  # the older name
        self.query_dim = int(query_dim)
        self.query_range = as_ranges(query_range, self.query_dim)
        self.n_grid = int(n_grid)
        self.regularizer = regularization
        self.encoder_cell = bool(encoder_cell)
        self.n_sensors = int(n_sensors)
        self.n_outputs = int(n_outputs)
        self.hidden_size = hidden_size
        self.num_layers = num_layers
        self.initial_state = bool(initial_state)
        self._spline = GridSpline(*self.query_range[0], self.n_grid)
        lo = np.array([r[0] for r in self.query_range])
        self._scale = (lo, 2.0 / (np.array([r[1] for r in self.query_range]) - lo))
        self.encoder = nn.LSTM(3 if self.initial_state else 1, hidden_size, num_layers,
                               batch_first=True)
        self.mu = nn.Linear(hidden_size, latent_dim)
        self.logvar = nn.Linear(hidden_size, latent_dim)
        states = 1 if self.encoder_cell else 2  # h only, or h and c, from z
        self.init_states = nn.ModuleList(
            nn.Linear(latent_dim, states * num_layers * hidden_size)
            for _ in range(n_outputs))
        reads = self.query_dim if self.query_coupled else 1  # features per decoder step
        self.decoders = nn.ModuleList(
            nn.LSTM(reads, hidden_size, num_layers, batch_first=True)
            for _ in range(n_outputs))
        self.heads = nn.ModuleList(nn.Linear(hidden_size, 1) for _ in range(n_outputs))
        self.kl = None
        self.noise = None
        match_default_float(self)

    def _scaled(self, x: torch.Tensor) -> torch.Tensor:
        """(M, d) points → (M, d) decoder inputs 2 (x − lo) / (hi − lo)."""
        lo, scale = self._scale
        if self.query_dim == 1:  # Python floats: exact for the default range (0, 2)
            return (x - float(lo[0])) * float(scale[0])
        return ((x - torch.as_tensor(lo, dtype=x.dtype, device=x.device))
                * torch.as_tensor(scale, dtype=x.dtype, device=x.device))

    def _latent(self, V: torch.Tensor):
        V, state = self._sensors_and_state(V)
        steps = V[..., None]
        if state is not None:
            steps = torch.cat([steps, state[:, None, :].expand(-1, V.shape[1], -1)], dim=-1)
        _, (h, c) = self.encoder(steps)
        h = h[-1]
        mu, logvar = self.mu(h), self.logvar(h)
        self.kl = torch.mean(-0.5 * torch.sum(1 + logvar - mu**2 - logvar.exp(), dim=-1))
        if self.training:
            eps = torch.randn_like(mu) if self.noise is None else self.noise(mu)
            return mu + torch.exp(0.5 * logvar) * eps, c
        return mu, c

    def _decode(self, z: torch.Tensor, c: torch.Tensor, steps: torch.Tensor,
                copies: int = 1, by_hand: bool = False) -> torch.Tensor:
        """Run every decoder on ``steps`` (B · copies, L, features) from the states of z
        (each row of z serving ``copies`` consecutive sequences); (B · copies, L, k).
        ``by_hand``: the LSTM equations in plain torch operations (twice differentiable
        in ``steps`` on every device; cuDNN's LSTM has no double backward)."""
        outs = []
        for init, decoder, head in zip(self.init_states, self.decoders, self.heads, strict=True):
            state = init(z).view(z.shape[0], -1, self.num_layers, self.hidden_size)
            h0 = state[:, 0].transpose(0, 1)
            c0 = c if self.encoder_cell else state[:, 1].transpose(0, 1)
            if copies > 1:
                h0, c0 = (s.repeat_interleave(copies, dim=1) for s in (h0, c0))
            if by_hand:
                seq = lstm_by_hand(cast(nn.LSTM, decoder), steps, h0, c0)
            else:
                seq, _ = decoder(steps, (h0.contiguous(), c0.contiguous()))
            outs.append(head(seq))
        return torch.cat(outs, dim=-1)

    def _forward(self, V: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        z, c = self._latent(V)
        batch = z.shape[0]
        if self.query_coupled:
            return self._decode(z, c, self._scaled(t)[None].expand(batch, -1, -1))
        if self.query_dim > 1:  # each point on its own: a sequence of its d coordinates
            points = t.shape[0]
            steps = self._scaled(t)[None].expand(batch, -1, -1).reshape(-1, self.query_dim, 1)
            y = self._decode(z, c, steps, copies=points, by_hand=True)[:, -1]
            return y.view(batch, points, self.n_outputs)
        nodes = self._spline.nodes
        grid = torch.tensor(nodes, dtype=t.dtype, device=t.device)[:, None]
        on_grid = t.shape == grid.shape and not t.requires_grad and torch.equal(t, grid)
        self._spline.check(t[:, 0], "VaRONet's query points (query_coupled=False)")
        steps = torch.tensor(self._scaled_nodes(), dtype=t.dtype, device=t.device)
        y = self._decode(z, c, steps[None, :, None].expand(batch, -1, -1))
        if on_grid:
            return y
        return self._spline(y.transpose(1, 2), t[:, 0]).transpose(1, 2)

    def _scaled_nodes(self) -> np.ndarray:
        lo, scale = self._scale
        return (self._spline.nodes - lo[0]) * scale[0]


def lstm_by_hand(lstm: nn.LSTM, steps: torch.Tensor, h0: torch.Tensor,
                 c0: torch.Tensor) -> torch.Tensor:
    """``nn.LSTM``'s forward (batch first, unidirectional) in plain torch operations.

    Args:
        lstm: the module whose weights are used.
        steps: (N, L, input_size) inputs.
        h0, c0: (num_layers, N, hidden_size) initial states.

    Returns:
        (N, L, hidden_size): the last layer's hidden states, as ``lstm(steps, (h0, c0))[0]``
        to rounding; differentiable any number of times on any device.

    Example:
        >>> lstm = nn.LSTM(1, 3, 2, batch_first=True)
        >>> x, h = torch.randn(4, 5, 1), torch.zeros(2, 4, 3)
        >>> torch.allclose(lstm_by_hand(lstm, x, h, h), lstm(x, (h, h))[0], atol=1e-6)
        True
    """
    out = steps
    for layer in range(lstm.num_layers):
        w_ih, w_hh = getattr(lstm, f"weight_ih_l{layer}"), getattr(lstm, f"weight_hh_l{layer}")
        bias = getattr(lstm, f"bias_ih_l{layer}") + getattr(lstm, f"bias_hh_l{layer}")
        h, c = h0[layer], c0[layer]
        inputs = out @ w_ih.T + bias  # (N, L, 4 H): gates i, f, g, o
        hs = []
        for step in range(out.shape[1]):
            i, f, g, o = (inputs[:, step] + h @ w_hh.T).chunk(4, dim=-1)
            c = torch.sigmoid(f) * c + torch.sigmoid(i) * torch.tanh(g)
            h = torch.sigmoid(o) * torch.tanh(c)
            hs.append(h)
        out = torch.stack(hs, dim=1)
    return out
