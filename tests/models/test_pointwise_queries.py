"""Networks on DeepXDE's other operator problems: d-D query points, k outputs, pointwise
derivatives (``query_coupled=False``), DeepXDE's regularization and default float."""

import warnings

import numpy as np
import pytest
import torch
from model_helpers import advection_operator_data

import nh_operators as nh
from nh_operators.models import cast_network

dde = pytest.importorskip("deepxde")

#: Tiny uncoupled versions of the networks under test, smooth (GELU) so that second
#: derivatives exist everywhere; add an entry to test another network.
POINTWISE = {
    "deeponet": dict(hidden_size=16, hidden_layers=2, branches=4),
    "traonet": dict(d_model=16, nhead=2, num_layers=1, dim_feedforward=32,
                    activation="gelu", time_scale=3.0),
    "mambonet": dict(d_model=16, num_mamba_layers=1, nhead=2, num_decoder_layers=1,
                     dim_feedforward=32, activation="gelu", time_scale=3.0),
    "varonet": dict(hidden_size=16, num_layers=1, latent_dim=3, n_grid=12),
    "fno": dict(n_modes=4, hidden_channels=4, n_layers=1, n_grid=12),
}
NAMES = list(POINTWISE)
#: The networks whose paper decoder couples the query points.
COUPLED = ["traonet", "mambonet"]


def pointwise(name, query_dim, n_outputs=2, dtype=torch.float64, seed=0, **kw):
    torch.manual_seed(seed)
    net = nh.build_model(name, "cpu", **{**POINTWISE[name], **kw}, query_coupled=False,
                         query_dim=query_dim, n_outputs=n_outputs)
    return cast_network(net, dtype).eval()


def data(query_dim, batch=2, m=5, dtype=torch.float64, seed=1):
    g = torch.Generator().manual_seed(seed)
    V = (torch.rand(batch, 100, generator=g) * 4 - 2).to(dtype)
    x = torch.rand(m, query_dim, generator=g).to(dtype)
    return V, x


def full_jacobian(net, V, x):
    """(B, M, k, M, d): d y[b, i, c] / d x[j, a]."""
    return torch.autograd.functional.jacobian(lambda z: net((V, z)), x)


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
@pytest.mark.parametrize("query_dim", [1, 2])
@pytest.mark.parametrize("name", NAMES)
def test_a_point_depends_on_itself_only(name, query_dim, dtype):
    net = pointwise(name, query_dim, dtype=dtype)
    assert net.query_coupled is False
    V, x = data(query_dim, dtype=dtype)
    J = full_jacobian(net, V, x)
    assert J.shape == (2, 5, 2, 5, query_dim)
    eye = torch.eye(5, dtype=torch.bool)[None, :, None, :, None].expand_as(J)
    assert J[~eye].abs().max().item() == 0.0   # not one off-diagonal term
    assert J[eye].abs().min().item() > 0.0     # every point moves its own prediction
    # the second derivatives exist in this dtype (the attention has a double backward)
    xg = x.clone().requires_grad_()
    y = net((V, xg))
    dde.grad.clear()
    H = dde.grad.hessian(y[0], xg, component=1, i=query_dim - 1, j=0)
    assert H.shape == (5, 1) and H.dtype == dtype and torch.isfinite(H).all()
    assert H.abs().max().item() > 0.0


@pytest.mark.parametrize("name", COUPLED)
def test_the_papers_decoder_has_off_diagonal_terms(name):
    """The contrast to the test above: the default (coupled) decoder fails it."""
    torch.manual_seed(0)
    net = cast_network(nh.build_model(name, "cpu", **POINTWISE[name]), torch.float64)
    assert net.query_coupled is True
    V, x = data(1)
    J = full_jacobian(net.eval(), V, x)
    eye = torch.eye(5, dtype=torch.bool)[None, :, None, :, None].expand_as(J)
    assert J[~eye].abs().max().item() > 1e-4


def shifted(net, V, x, steps):
    """Network outputs at x + Σ h e_axis over the (h, axis) steps: every point moved
    alike, which gives each point's own derivative since the network is pointwise."""
    z = x.clone()
    for h, axis in steps:
        z[:, axis] += h
    with torch.no_grad():
        return net((V, z))


@pytest.mark.parametrize("query_dim", [1, 2])
@pytest.mark.parametrize("name", NAMES)
def test_dde_grad_gives_the_pointwise_derivatives(name, query_dim):
    """dde.grad.jacobian / hessian as PDEOperatorCartesianProd calls them (per function,
    outputs (M, k)) against autograd and central differences (float64, h = 1e-4)."""
    k, h = 2, 1e-4
    net = pointwise(name, query_dim, n_outputs=k)
    V, x = data(query_dim)
    xg = x.clone().requires_grad_()
    y = net((V, xg))                               # (B, M, k)
    J = full_jacobian(net, V, x)                   # (B, M, k, M, d)
    idx = torch.arange(5)
    for b in range(len(V)):
        dde.grad.clear()
        for c in range(k):
            for a in range(query_dim):
                du = dde.grad.jacobian(y[b], xg, i=c, j=a)[:, 0]
                torch.testing.assert_close(du, J[b, idx, c, idx, a], rtol=1e-12, atol=1e-12)
                fd = (shifted(net, V, x, [(h, a)]) - shifted(net, V, x, [(-h, a)]))[b, :, c]
                torch.testing.assert_close(du, fd / (2 * h), rtol=1e-5,
                                           atol=1e-6 * du.abs().max().item())
                for a2 in range(query_dim):
                    d2u = dde.grad.hessian(y[b], xg, component=c, i=a, j=a2)[:, 0]
                    fd2 = (shifted(net, V, x, [(h, a), (h, a2)])
                           - shifted(net, V, x, [(h, a), (-h, a2)])
                           - shifted(net, V, x, [(-h, a), (h, a2)])
                           + shifted(net, V, x, [(-h, a), (-h, a2)]))[b, :, c] / (4 * h * h)
                    torch.testing.assert_close(d2u, fd2, rtol=1e-5,
                                               atol=1e-5 * d2u.abs().max().item())
    # one output: (B, M), and PDEOperatorCartesianProd's out[:, None]
    net1 = pointwise(name, query_dim, n_outputs=1)
    y1 = net1((V, xg))
    assert y1.shape == (2, 5)
    dde.grad.clear()
    d2 = dde.grad.hessian(y1[1][:, None], xg, i=0, j=0)[:, 0]
    fd2 = (shifted(net1, V, x, [(h, 0)]) - 2 * shifted(net1, V, x, [])
           + shifted(net1, V, x, [(-h, 0)]))[1] / h ** 2
    torch.testing.assert_close(d2, fd2, rtol=1e-4, atol=1e-4 * d2.abs().max().item())


@pytest.mark.parametrize("name", COUPLED)
def test_a_coupled_network_warns_once_when_differentiated_in_its_queries(name):
    torch.manual_seed(0)
    net = nh.build_model(name, "cpu", **POINTWISE[name])
    V, x = data(1, dtype=torch.float32)
    x.requires_grad_()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        net((V, x)).square().mean().backward()    # data-driven training: no warning
        with torch.no_grad():
            net((V, x))
    y = net((V, x))
    dde.grad.clear()
    with pytest.warns(UserWarning, match="not pointwise"):
        dde.grad.jacobian(y[0], x, i=0, j=0)
    y = net((V, x))
    dde.grad.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("error")               # once per network
        dde.grad.jacobian(y[1], x, i=1, j=0)
    torch.manual_seed(0)
    with pytest.warns(UserWarning, match="query_coupled=False"):   # per network
        other = nh.build_model(name, "cpu", **POINTWISE[name])
        dde.grad.clear()
        dde.grad.jacobian(other((V, x))[0], x, i=0, j=0)


@pytest.mark.parametrize("name", NAMES)
def test_k_outputs_on_d_dimensional_queries(name):
    net = pointwise(name, 2, n_outputs=3, dtype=torch.float32)
    V, x = data(2, batch=4, m=6, dtype=torch.float32)
    assert net((V, x)).shape == (4, 6, 3)
    with pytest.raises(ValueError, match=r"query points must have shape \(M, 2\)"):
        net((V, x[:, :1]))
    with pytest.raises(ValueError, match="query_dim=3"):
        net((V, torch.rand(6, 3)))
    m7 = pointwise(name, 3, n_outputs=1, dtype=torch.float32, n_sensors=7)
    assert m7((V[:, :7], torch.rand(6, 3))).shape == (4, 6)


@pytest.mark.parametrize("name", NAMES)
def test_regularization_reaches_deepxde(name):
    torch.manual_seed(0)
    net = nh.build_model(name, "cpu", **POINTWISE[name], regularization=("l2", 1e-3))
    assert net.regularizer == ("l2", 1e-3)
    assert nh.build_model(name, "cpu", **POINTWISE[name]).regularizer is None
    # DeepXDE reads it at compile: with Adam, l2 becomes the weight decay
    V, x = data(1, dtype=torch.float32)
    y = net((V, x)).detach().numpy()
    d = dde.data.TripleCartesianProd((V.numpy(), x.numpy()), y, (V.numpy(), x.numpy()), y)
    model = dde.Model(d, net)
    model.compile("adam", lr=1e-3)
    assert model.opt.param_groups[0]["weight_decay"] == 1e-3


@pytest.mark.parametrize("name", NAMES)
def test_deepxde_default_float_is_respected_at_construction(name):
    try:
        dde.config.set_default_float("float64")
        torch.set_default_dtype(torch.float32)   # DeepXDE's setting rules, not torch's
        torch.manual_seed(0)
        net = nh.build_model(name, "cpu", **POINTWISE[name], query_dim=2,
                             query_coupled=False)
    finally:
        dde.config.set_default_float("float32")
    dtypes = {t.dtype for t in [*net.parameters(), *net.buffers()] if t.is_floating_point()}
    assert dtypes == {torch.float64}
    V, x = data(2, dtype=torch.float64)
    assert net((V, x)).dtype == torch.float64
    assert nh.build_model(name, "cpu", **POINTWISE[name]).state_dict()[
        next(iter(net.state_dict()))].dtype == torch.float32


def test_query_coupled_is_the_canonical_switch():
    kw = POINTWISE["traonet"]
    for name in COUPLED:
        cls = nh.models.MODELS[name]
        assert nh.build_model(name, "cpu", **POINTWISE[name]).query_coupled is True
        assert nh.build_model(name, "cpu", **POINTWISE[name],
                              query_attention=False).query_coupled is False
        same = nh.build_model(name, "cpu", **POINTWISE[name], query_attention=False,
                              query_coupled=False)
        assert same.query_coupled is False and cls is type(same)
        with pytest.raises(ValueError, match="disagree"):
            nh.build_model(name, "cpu", **POINTWISE[name], query_attention=True,
                           query_coupled=False)
    with pytest.raises(ValueError, match="cannot couple"):
        nh.build_model("deeponet", "cpu", query_coupled=True)
    with pytest.raises(ValueError, match="at least 2 × query_dim"):
        nh.build_model("traonet", "cpu", **{**kw, "d_model": 4, "nhead": 1}, query_dim=3)
    with pytest.raises(ValueError, match="one scale per query coordinate"):
        nh.build_model("traonet", "cpu", **{**kw, "time_scale": (1.0, 2.0)}, query_dim=3)


@pytest.mark.parametrize("kw", [dict(query_dim=2), dict(n_outputs=3)])
def test_phaseonet_says_it_serves_the_hamiltonian_problem_only(kw):
    with pytest.raises(ValueError, match="only the 1-D Hamiltonian problem"):
        nh.build_model("phaseonet", "cpu", **kw)


def test_query_encoding_of_one_coordinate_is_the_papers():
    from nh_operators.models._decoder import query_encoding
    from nh_operators.models._layers import sinusoidal

    t = torch.tensor(nh.TIMES, dtype=torch.float32)[:, None]
    assert torch.equal(query_encoding(t, (99 / 2,), 64), sinusoidal(t[:, 0] * (99 / 2), 64))
    # two coordinates: frequency j reads coordinate j mod 2 (sin at 2j, cos at 2j + 1)
    x = torch.tensor([[0.3, 0.7]], dtype=torch.float64)
    enc = query_encoding(x, (2.0, 5.0), 8)[0]
    for j in range(4):
        pos = (0.3 * 2.0, 0.7 * 5.0)[j % 2] * 10000.0 ** (-2 * j / 8)
        torch.testing.assert_close(enc[2 * j:2 * j + 2],
                                   torch.tensor([np.sin(pos), np.cos(pos)],
                                                dtype=torch.float64))


@pytest.mark.parametrize("name", NAMES)
def test_physics_informed_training_on_x_t_lowers_the_loss(name):
    """Advection u_t + u_x = 0 on (x, t) ∈ [0, 1]², u(x, 0) = v(x): DeepXDE's
    PDEOperatorCartesianProd with 2-D query points, 20 Adam steps."""
    data_obj = advection_operator_data(12, 6, num_domain=20, num_initial=8)
    torch.manual_seed(0)
    net = nh.build_model(name, "cpu", **POINTWISE[name], n_sensors=12, n_outputs=1,
                         query_dim=2, query_coupled=False)
    model = dde.Model(data_obj, net)
    model.compile("adam", lr=1e-2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)   # uncoupled: no warning
        losshistory, _ = model.train(iterations=20, display_every=20, verbose=0)
    first, last = (np.sum(losshistory.loss_train[i]) for i in (0, -1))
    assert np.isfinite(last) and last < 0.9 * first


@pytest.mark.gpu
@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
@pytest.mark.parametrize("name", NAMES)
def test_pointwise_derivatives_on_cuda_match_the_cpu(name, dtype, monkeypatch):
    # TF32 (PyTorch's CUDA default for convolutions) rounds FNO's float32 spectral layer
    # to ~7e-4 of its values, and its second derivatives 16 % off (H200): off here, as
    # docs/any_problem.md tells physics-informed users to do
    monkeypatch.setattr(torch.backends.cudnn, "allow_tf32", False)
    monkeypatch.setattr(torch.backends.cuda.matmul, "allow_tf32", False)
    net = pointwise(name, 2, n_outputs=2)
    V, x = data(2)
    xg = x.clone().requires_grad_()
    dde.grad.clear()
    ref = dde.grad.hessian(net((V, xg))[0], xg, component=1, i=1, j=0)
    gpu = cast_network(net, dtype).cuda()
    V, xc = V.to("cuda", dtype), x.to("cuda", dtype).requires_grad_()
    J = full_jacobian(gpu, V, xc.detach())
    eye = torch.eye(5, dtype=torch.bool, device="cuda")[None, :, None, :, None].expand_as(J)
    assert J[~eye].abs().max().item() == 0.0
    dde.grad.clear()
    H = dde.grad.hessian(gpu((V, xc))[0], xc, component=1, i=1, j=0)
    tol = 1e-9 if dtype == torch.float64 else 1e-3
    if name == "fno" and dtype == torch.float64:
        # cuFFT's spectral layer leaves the CPU's by 5e-9 of the values; the
        # second derivative by 7e-7 (H200)
        tol = 1e-5
    torch.testing.assert_close(H.cpu().double(), ref.detach(), rtol=tol,
                               atol=tol * ref.abs().max().item())
