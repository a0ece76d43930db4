"""The authors' DeepONet and VaRONet (reference code at 5c4cbd8), as DeepXDE networks.

Each class computes the function the authors' network computes, weight for weight, and
its parameters carry the authors' ``state_dict`` key names, so a checkpoint of theirs
loads with ``load_state_dict(strict=True)`` (:func:`~nh_operators.models.from_reference`
does it from their ``net_config``). Their differences from our networks are listed in
``docs/models.md``.
"""

import torch
from torch import nn

from ._layers import OperatorNet

__all__ = ["ReferenceDeepONet", "ReferenceVaRONet"]


class ReferenceDeepONet(OperatorNet):
    """The authors' DeepONet.

    Branch: V (B, m) → Linear(m, h) → GELU → Linear(h, 2l); trunk: t (M, 1) →
    Linear(1, h) → GELU → Linear(h, 2l) (one hidden layer: the reference builds
    h = nodes · (layers − 1) by a list bug, where the paper describes ``layers`` layers
    of ``nodes``). Both outputs are viewed as (l, 2): feature 2k + c belongs to output c
    (c = 0 for q, 1 for p), and output c is Σ_k branch[k, c] · trunk[k, c] + bias[c].

    Args:
        hidden_size: width h of the hidden layer (the authors' paper size: 256, from
            nodes 128, layers 3).
        branches: basis functions per output, l (paper: 10).
        n_sensors: length m of V (default 100).

    Input ``(V, t)``: V (B, m), t (M, 1); output (B, M, 2).

    Example:
        >>> import torch
        >>> net = ReferenceDeepONet(hidden_size=8, branches=3)
        >>> net((torch.zeros(2, 100), torch.zeros(5, 1))).shape
        torch.Size([2, 5, 2])
    """

    def __init__(self, hidden_size=256, branches=10, n_sensors=100):
        super().__init__()
        self.n_sensors = n_sensors
        self.branches = branches
        self.branch_net = _mlp(n_sensors, hidden_size, 2 * branches)
        self.trunk_net = _mlp(1, hidden_size, 2 * branches)
        self.bias = nn.Parameter(torch.zeros(2))

    def _forward(self, V, t):
        b = self.branch_net(V).view(V.shape[0], self.branches, 2)
        k = self.trunk_net(t).view(t.shape[0], self.branches, 2)
        return torch.einsum("bkc,mkc->bmc", b, k) + self.bias


def _mlp(n_in, hidden, n_out):
    return nn.Sequential(nn.Linear(n_in, hidden), nn.GELU(), nn.Linear(hidden, n_out))


class _Encoder(nn.Module):
    def __init__(self, hidden_size, num_layers, dropout):
        super().__init__()
        self.rnn = nn.LSTM(1, hidden_size, num_layers, batch_first=True,
                           dropout=dropout, bidirectional=True)


class _Decoder(nn.Module):
    def __init__(self, hidden_size, num_layers, dropout):
        super().__init__()
        self.rnn = nn.LSTM(1, hidden_size, num_layers, batch_first=True,
                           dropout=dropout, bidirectional=True)
        self.fc = nn.Linear(2 * hidden_size, 1)

    def forward(self, times, state):
        return self.fc(self.rnn(times, state)[0])


class ReferenceVaRONet(OperatorNet):
    """The authors' VaRONet: bidirectional LSTMs and one latent per layer and direction.

    The encoder, a bidirectional L-layer LSTM, reads V(x_1), ..., V(x_m). Each of its
    2L final hidden states h_k (one per layer and direction) gives a latent:
    μ_k = F_μ(h_k), log σ²_k = F_σ(h_k), z_k = μ_k + σ_k ⊙ ε in training mode and
    z_k = μ_k in eval mode (the reference samples at test time too; we do not). Two
    bidirectional decoders (q and p) start from h_k = F_x(z_k) (or F_p(z_k)) and
    c_k = the encoder's final cell state k, read the query times as a sequence, and end
    in Linear(2H, 1). Because the decoders read the times forwards *and* backwards,
    every prediction depends on all the times asked in the same call
    (``query_coupled``): ask for :data:`~nh_operators.TIMES`.

    After every forward, ``mu`` and ``logvar`` hold the latents' parameters, shape
    (B, 2L, Z), batch first (layer-direction k as PyTorch orders ``h_n``), and ``kl``
    the batch mean of KL(N(μ, σ²) ‖ N(0, I)) summed over all 2L·Z entries, which the
    training data (:class:`nh_operators.OperatorData`) reads exactly as it reads our
    VaRONet's. The reference's own KL term is β times the *mean* over the entries:
    β · kl / (2L·Z).

    Args:
        hidden_size: LSTM width H (paper: 512).
        num_layers: layers L of every LSTM (paper: 4).
        latent_dim: size Z of each latent (the authors' ``latent_size``; paper: 30).
        dropout: dropout between LSTM layers (training mode only; default 0).
        kl_weight: the authors' β, kept as an attribute for a training recipe to read;
            the forward does not use it (:class:`~nh_operators.TrainConfig` takes β as
            ``beta``). Default ``None``.
        n_sensors: length m of V (default 100).

    Attributes:
        noise: ``None`` (ε = ``torch.randn_like(μ)``) or a callable ``noise(mu)``
            returning ε of μ's shape, as for :class:`~nh_operators.models.VaRONet`.

    Input ``(V, t)``: V (B, m), t (M, 1); output (B, M, 2).

    Example:
        >>> import torch
        >>> net = ReferenceVaRONet(hidden_size=8, num_layers=2, latent_dim=3).eval()
        >>> y = net((torch.zeros(4, 100), torch.linspace(0, 2, 6)[:, None]))
        >>> y.shape, net.mu.shape
        (torch.Size([4, 6, 2]), torch.Size([4, 4, 3]))
    """

    query_coupled = True  # the decoders read the times as a sequence, both ways

    def __init__(self, hidden_size=512, num_layers=4, latent_dim=30, dropout=0.0,
                 kl_weight=None, n_sensors=100):
        super().__init__()
        self.n_sensors = n_sensors
        self.kl_weight = kl_weight
        self.branch_net = _Encoder(hidden_size, num_layers, dropout)
        self.trunk_x_net = _Decoder(hidden_size, num_layers, dropout)
        self.trunk_p_net = _Decoder(hidden_size, num_layers, dropout)
        self.fc_mu = nn.Linear(hidden_size, latent_dim)
        self.fc_var = nn.Linear(hidden_size, latent_dim)
        self.fc_z_x = nn.Linear(latent_dim, hidden_size)
        self.fc_z_p = nn.Linear(latent_dim, hidden_size)
        self.mu = self.logvar = self.kl = None
        self.noise = None

    def _forward(self, V, t):
        _, (h, c) = self.branch_net.rnn(V[..., None])  # (2L, B, H) each
        mu, logvar = self.fc_mu(h), self.fc_var(h)  # (2L, B, Z)
        self.mu, self.logvar = mu.transpose(0, 1), logvar.transpose(0, 1)
        self.kl = torch.mean(-0.5 * torch.sum(1 + logvar - mu**2 - logvar.exp(),
                                              dim=(0, 2)))
        if self.training:
            eps = torch.randn_like(mu) if self.noise is None else self.noise(mu)
            z = mu + torch.exp(0.5 * logvar) * eps
        else:
            z = mu
        times = t[None].expand(V.shape[0], -1, -1)
        q = self.trunk_x_net(times, (self.fc_z_x(z).contiguous(), c))
        p = self.trunk_p_net(times, (self.fc_z_p(z).contiguous(), c))
        return torch.cat([q, p], dim=-1)
