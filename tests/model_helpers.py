"""Shared helpers of the network tests: tiny architectures and random inputs."""

import torch

import nh_operators as nh

#: Tiny versions of every network (fast on a CPU).
TINY = {
    "deeponet": dict(hidden_size=16, hidden_layers=2, branches=4),
    "traonet": dict(d_model=16, nhead=2, num_layers=1, dim_feedforward=32),
    "varonet": dict(hidden_size=8, num_layers=1, latent_dim=4),
    "mambonet": dict(d_model=16, num_mamba_layers=1, nhead=2, num_decoder_layers=1,
                     dim_feedforward=32),
    "fno": dict(n_modes=8, hidden_channels=8, n_layers=2),
    "phaseonet": dict(width=16, depth=1, basis=4, grid=16),
}


def tiny(name, seed=0, **kw):
    torch.manual_seed(seed)
    return nh.build_model(name, "cpu", **{**TINY[name], **kw})


def inputs(batch=3, m=7, dtype=torch.float32, seed=1):
    g = torch.Generator().manual_seed(seed)
    V = torch.rand(batch, 100, generator=g, dtype=dtype) * 4 - 2
    t = torch.sort(torch.rand(m, generator=g, dtype=dtype) * 2).values[:, None]
    return V, t
