"""VaRONet: an LSTM encoder, a Gaussian latent, and LSTM decoders for q and p."""

import numpy as np
import torch
from torch import nn

from .._constants import TIMES
from ._layers import OperatorNet

__all__ = ["VaRONet"]


class VaRONet(OperatorNet):
    """Variational recurrent operator network (the paper's §2.2).

    An LSTM reads V(x_1), ..., V(x_m); its last hidden state h gives μ = F_μ(h) and
    log σ² = F_σ(h). In training z = μ + σ ⊙ ε with ε ~ N(0, I) (the
    reparameterisation trick); in eval mode z = μ, so predictions are deterministic.
    Linear maps of z give the initial hidden and cell states of two LSTM decoders,
    which read the query times in order and emit q and p through Linear(H, 1) heads.

    After every forward, ``self.kl`` holds the batch mean of
    KL(N(μ, σ²) ‖ N(0, I)) = −½ Σ (1 + log σ² − μ² − σ²); the training data object
    (:class:`nh_operators.OperatorData`) adds β · kl / (2M) to DeepXDE's mean-squared
    data loss as its own column, which is the paper's loss Σ (error²) + β · KL per
    sample divided by its 2M outputs.

    **The encoder's cell states** (``encoder_cell=True``). The reference code that
    produced the paper's tables starts each decoder from h = a map of z and
    c = the encoder's final cell states, layer by layer: a deterministic path of
    ``num_layers * hidden_size`` numbers beside the latent, which the KL term does not
    constrain. The paper's text describes only the latent. With the default
    (``False``), both h and c come from z, and the latent is the only path; the KL term
    then trades precision for nats (docs/recipe.md measures what the option changes).

    Args:
        hidden_size: LSTM width H (paper: 512).
        num_layers: layers of every LSTM (paper: 4).
        latent_dim: size of z (paper: 30).
        n_sensors: length m of V (default 100).
        n_outputs: decoders, 2 for (q, p) (1 gives shape (B, M)).
        encoder_cell: start the decoders' cell states from the encoder's (see above).
        grid_decoder: the decoders always read the training grid
            (:data:`~nh_operators.TIMES`) and the asked times are read off their
            outputs by a not-a-knot cubic spline, so a prediction at t does not depend
            on the other times asked (``query_coupled`` is False; on the grid itself the
            spline is skipped, so training is unchanged). Times must lie in [0, 2].
            ``False``: the decoders read the asked times as their sequence, as the
            paper describes; a prediction then changes with its company.
        initial_state: True: V carries (q0, p0) after the sensors, (B, m + 2), and the
            encoder reads (V(x_j), q0, p0) at every step (default False: rest at
            q = 0).

    Attributes:
        noise: ``None`` (ε = ``torch.randn_like(μ)``) or a callable ``noise(mu)``
            returning ε of μ's shape; a distributed run sets it to
            :meth:`~nh_operators.data.ShardedOperatorData.batch_noise`, which draws the
            global batch's noise and slices this rank's rows, so N processes draw what
            one would.

    Input ``(V, t)``: V (B, m), t (M, 1); output (B, M, n_outputs). With
    ``grid_decoder=False`` the decoders read the times as a sequence, so ask for them in
    increasing order.

    Example:
        >>> import torch
        >>> net = VaRONet(hidden_size=8, num_layers=1, latent_dim=4).eval()
        >>> y = net((torch.zeros(3, 100), torch.linspace(0, 2, 6)[:, None]))
        >>> y.shape, net.kl.shape
        (torch.Size([3, 6, 2]), torch.Size([]))
    """

    def __init__(self, hidden_size=512, num_layers=4, latent_dim=30, n_sensors=100,
                 n_outputs=2, encoder_cell=False, grid_decoder=True, initial_state=False):
        super().__init__()
        self.encoder_cell = bool(encoder_cell)
        self.grid_decoder = bool(grid_decoder)
        # without the grid, the LSTM decoders read the query times as a sequence
        self.query_coupled = not self.grid_decoder
        self._weights = (None, None)  # (asked times, spline weights) of the last call
        self.n_sensors = n_sensors
        self.n_outputs = n_outputs
        self.hidden_size = hidden_size
        self.num_layers = num_layers
        self.initial_state = bool(initial_state)
        self.encoder = nn.LSTM(3 if self.initial_state else 1, hidden_size, num_layers,
                               batch_first=True)
        self.mu = nn.Linear(hidden_size, latent_dim)
        self.logvar = nn.Linear(hidden_size, latent_dim)
        states = 1 if self.encoder_cell else 2  # h only, or h and c, from z
        self.init_states = nn.ModuleList(
            nn.Linear(latent_dim, states * num_layers * hidden_size)
            for _ in range(n_outputs))
        self.decoders = nn.ModuleList(
            nn.LSTM(1, hidden_size, num_layers, batch_first=True)
            for _ in range(n_outputs))
        self.heads = nn.ModuleList(nn.Linear(hidden_size, 1) for _ in range(n_outputs))
        self.kl = None
        self.noise = None

    def _forward(self, V, t):
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
            z = mu + torch.exp(0.5 * logvar) * eps
        else:
            z = mu
        asked = t
        if self.grid_decoder:
            t = torch.tensor(TIMES, dtype=t.dtype, device=t.device)[:, None]
            on_grid = asked.shape == t.shape and torch.equal(asked, t)
        times = t[None].expand(V.shape[0], -1, -1)
        outs = []
        for init, decoder, head in zip(self.init_states, self.decoders, self.heads):
            state = init(z).view(V.shape[0], -1, self.num_layers, self.hidden_size)
            h0 = state[:, 0].transpose(0, 1).contiguous()
            c0 = c if self.encoder_cell else state[:, 1].transpose(0, 1).contiguous()
            seq, _ = decoder(times, (h0, c0))
            outs.append(head(seq))
        y = torch.cat(outs, dim=-1)
        if not self.grid_decoder or on_grid:
            return y
        return torch.einsum("mg,bgo->bmo", self._spline(asked, y), y)

    def _spline(self, asked, y):
        """(M, 100) weights: row i gives the not-a-knot cubic spline through the grid
        values at asked time i."""
        key = asked.detach().cpu().numpy().reshape(-1).astype(np.float64)
        if self._weights[0] is None or not np.array_equal(self._weights[0], key):
            if key.size and (key.min() < -1e-9 or key.max() > TIMES[-1] + 1e-9):
                raise ValueError(f"VaRONet with grid_decoder=True predicts on t ∈ [0, "
                                 f"{TIMES[-1]:g}]; got t from {key.min():g} to "
                                 f"{key.max():g}")
            from scipy.interpolate import CubicSpline

            w = CubicSpline(TIMES, np.eye(TIMES.size), axis=0)(np.clip(key, 0, TIMES[-1]))
            self._weights = (key, w)
        return torch.as_tensor(self._weights[1], dtype=y.dtype, device=y.device)
