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


def advection_operator_data(n_sensors, n_functions, num_domain, num_initial):
    """DeepXDE's physics-informed advection u_t + u_x = 0 on (x, t) ∈ [0, 1]², with
    u(x, 0) = v(x) for v from a Chebyshev space: a PDEOperatorCartesianProd with 2-D
    query points (DeepXDE samples from NumPy's global generator: seeded here)."""
    import numpy as np
    from nh_operators._backend import ensure_pytorch_backend

    dde = ensure_pytorch_backend()
    geom = dde.geometry.GeometryXTime(dde.geometry.Interval(0, 1),
                                      dde.geometry.TimeDomain(0, 1))

    def pde(x, u, v):
        return dde.grad.jacobian(u, x, j=1) + dde.grad.jacobian(u, x, j=0)

    ic = dde.icbc.DirichletBC(geom, lambda x, v: v, lambda x, _: np.isclose(x[1], 0))
    np.random.seed(0)
    pde_data = dde.data.TimePDE(geom, pde, ic, num_domain=num_domain,
                                num_initial=num_initial, train_distribution="uniform")
    return dde.data.PDEOperatorCartesianProd(
        pde_data, dde.data.Chebyshev(N=4), np.linspace(0, 1, n_sensors)[:, None],
        n_functions, function_variables=[0])
