"""VaRONet and FNO on other operator problems: d-D query points, pointwise derivatives
through DeepXDE's ``dde.grad``, the spline read-out, the KL term in any data object."""

import contextlib
import io
import sys

import numpy as np
import pytest
import torch
from model_helpers import advection_operator_data
from scipy.interpolate import CubicSpline

from nh_operators._backend import ensure_pytorch_backend
from nh_operators.models import FNO, KLData, VaRONet
from nh_operators.models.readout import GridSpline, as_ranges, not_a_knot_matrix, tensor_spline

dde = ensure_pytorch_backend()
CUDA = torch.cuda.is_available()


@contextlib.contextmanager
def default_float(name):
    """DeepXDE's default float set to ``name`` inside the block (quietly), then float32."""
    with contextlib.redirect_stdout(io.StringIO()):
        dde.config.set_default_float(name)
    try:
        yield
    finally:
        with contextlib.redirect_stdout(io.StringIO()):
            dde.config.set_default_float("float32")


def _net(kind, d, seed=0, **kw):
    torch.manual_seed(seed)
    if kind == "varonet":
        kw = dict(hidden_size=6, num_layers=2, latent_dim=3, n_grid=12, **kw)
        return VaRONet(n_sensors=10, query_dim=d, query_range=(0.0, 1.0), **kw).eval()
    kw = dict(n_modes=4, hidden_channels=4, n_layers=1, n_grid=12 if d > 1 else 16, **kw)
    return FNO(n_sensors=10, query_dim=d, query_range=(0.0, 1.0), **kw).eval()


def _points(d, n_grid, m=5, seed=0):
    """m points of [0, 1]^d, each coordinate well inside a cell of an n_grid grid (0.2 to
    0.8 of a cell), so a finite-difference stencil never crosses a spline knot."""
    rng = np.random.default_rng(seed)
    h = 1.0 / (n_grid - 1)
    cells = rng.integers(0, n_grid - 1, size=(m, d))
    return (cells + rng.uniform(0.2, 0.8, size=(m, d))) * h


def _sensors(dtype, b=2, seed=1):
    g = torch.Generator().manual_seed(seed)
    return torch.rand(b, 10, generator=g, dtype=torch.float64, device="cpu").to(dtype)


# ---------------------------------------------------------------- the spline read-out

def test_spline_reproduces_a_cubic_and_its_derivatives_exactly():
    spline = GridSpline(-1.0, 2.0, 7)
    nodes = torch.tensor(spline.nodes)
    cubic = lambda x: 0.5 - 1.5 * x + 2 * x**2 - 0.75 * x**3
    x = torch.tensor([-1.0, -0.93, 0.1, 0.5, 1.37, 2.0], dtype=torch.float64,
                     requires_grad=True)
    y = spline(cubic(nodes), x)
    (dy,) = torch.autograd.grad(y.sum(), x, create_graph=True)
    (d2y,) = torch.autograd.grad(dy.sum(), x)
    xd = x.detach()
    torch.testing.assert_close(y.detach(), cubic(xd), rtol=0, atol=1e-13)
    torch.testing.assert_close(dy.detach(), -1.5 + 4 * xd - 2.25 * xd**2, rtol=0, atol=1e-12)
    torch.testing.assert_close(d2y, 4 - 4.5 * xd, rtol=0, atol=1e-11)


@pytest.mark.parametrize("n", [2, 3, 4, 9])
def test_spline_is_scipys_not_a_knot_spline(n):
    rng = np.random.default_rng(n)
    spline = GridSpline(0.5, 3.0, n)
    values = rng.normal(size=(3, n))
    x = np.concatenate([[0.5, 3.0], rng.uniform(0.5, 3.0, 20)])
    expected = CubicSpline(spline.nodes, values, axis=1)(x)
    np.testing.assert_allclose(spline(torch.tensor(values), torch.tensor(x)).numpy(),
                               expected, rtol=0, atol=1e-13)
    # the second derivatives at the nodes, from the matrix
    np.testing.assert_allclose(not_a_knot_matrix(n, spline.spacing) @ values[0],
                               CubicSpline(spline.nodes, values[0])(spline.nodes, 2),
                               rtol=0, atol=1e-10)


def test_tensor_spline_reproduces_a_bicubic_polynomial_point_by_point():
    sx, sy = GridSpline(0.0, 1.0, 5), GridSpline(-1.0, 1.0, 6)
    f = lambda x, y: (1 + x - x**3) * (2 - y + 0.5 * y**2 + y**3)
    gx, gy = torch.tensor(sx.nodes), torch.tensor(sy.nodes)
    values = torch.stack([f(gx[:, None], gy[None, :]), -f(gx[:, None], gy[None, :])])
    pts = torch.tensor([[0.0, -1.0], [0.31, 0.77], [0.9, -0.2], [1.0, 1.0]],
                       dtype=torch.float64)
    out = tensor_spline([sx, sy], values, pts)
    assert out.shape == (2, 4)
    expected = f(pts[:, 0], pts[:, 1])
    torch.testing.assert_close(out, torch.stack([expected, -expected]), rtol=0, atol=1e-12)


def test_spline_and_range_errors():
    with pytest.raises(ValueError, match=r"query points must lie in \[0, 1\]; got values "
                                         r"from -0.5 to 0.5"):
        GridSpline(0.0, 1.0, 5)(torch.zeros(5), torch.tensor([-0.5, 0.5]))
    with pytest.raises(ValueError, match="at least 2 grid points, got 1"):
        not_a_knot_matrix(1)
    with pytest.raises(ValueError, match=r"one \(low, high\) pair or 2 of them"):
        as_ranges([(0, 1)] * 3, 2)
    with pytest.raises(ValueError, match=r"coordinate 1 must have low < high, got \(1, 1\)"):
        as_ranges([(0, 1), (1, 1)], 2)


# ---------------------------------------------------------------- pointwise derivatives

CASES = [(kind, d, dtype) for kind in ("varonet", "fno") for d in (1, 2)
         for dtype in ("float32", "float64")]


@pytest.mark.parametrize("kind,d,dtype", CASES)
def test_the_full_jacobian_over_the_query_points_is_block_diagonal(kind, d, dtype):
    with default_float(dtype):
        net = _net(kind, d)
        assert net.query_coupled is False and net.query_dim == d
        assert next(net.parameters()).dtype == getattr(torch, dtype)
        V = _sensors(getattr(torch, dtype))
        x = torch.tensor(_points(d, 12, m=6), dtype=getattr(torch, dtype))
        J = torch.autograd.functional.jacobian(lambda x: net((V, x)), x)  # (B, M, k, M, d)
    assert J.shape == (2, 6, 2, 6, d)
    off = ~torch.eye(6, dtype=torch.bool)[None, :, None, :, None].expand_as(J)
    assert torch.count_nonzero(J[off]) == 0
    assert torch.count_nonzero(J[~off]) > 0.9 * J[~off].numel()


def _dde_derivatives(net, V, x):
    """First and second derivatives as DeepXDE's PDEOperatorCartesianProd takes them:
    per function i, ``out = outputs[i]`` (M, k) against the shared points x (M, d)."""
    dde.grad.clear()
    outputs = net((V, x))
    if outputs.ndim == 2:
        outputs = outputs[..., None]
    d, k = x.shape[1], outputs.shape[2]
    first = torch.empty(V.shape[0], k, d, x.shape[0], dtype=x.dtype, device="cpu")
    second = torch.empty(V.shape[0], k, d, d, x.shape[0], dtype=x.dtype, device="cpu")
    for i in range(V.shape[0]):
        out = outputs[i]
        for c in range(k):
            for a in range(d):
                first[i, c, a] = dde.grad.jacobian(out, x, i=c, j=a)[:, 0].detach().cpu()
                for b in range(d):
                    second[i, c, a, b] = dde.grad.hessian(out, x, component=c, i=a,
                                                          j=b)[:, 0].detach().cpu()
    return first, second


def _central_differences(net, V, x):
    """(B, k, d, M) first and (B, k, d, d, M) second derivatives of the forward, every
    point shifted at once (the network is pointwise: see the Jacobian test)."""
    def f(shift):
        with torch.no_grad():
            return net((V, x + shift)).permute(0, 2, 1)  # (B, k, M)

    d = x.shape[1]
    e = torch.eye(d, dtype=x.dtype, device=x.device)
    h1, h2, hm = 1e-5, 1e-3, 3e-4
    first = torch.stack([(f(h1 * e[j]) - f(-h1 * e[j])) / (2 * h1) for j in range(d)], 2)
    rows = []
    for a in range(d):
        row = []
        for b in range(d):
            if a == b:
                row.append((f(h2 * e[a]) - 2 * f(0 * e[a]) + f(-h2 * e[a])) / h2**2)
            else:
                pa, pb = hm * e[a], hm * e[b]
                row.append((f(pa + pb) - f(pa - pb) - f(pb - pa) + f(-pa - pb)) / (4 * hm**2))
        rows.append(torch.stack(row, 2))
    return first, torch.stack(rows, 2)


def _check_derivatives(kind, d, device="cpu"):
    with default_float("float64"):
        net = _net(kind, d).to(device)
        V = _sensors(torch.float64).to(device)
        x = torch.tensor(_points(d, 12 if (kind == "varonet" or d > 1) else 16),
                         device=device).requires_grad_()
        first, second = _dde_derivatives(net, V, x)
        fd1, fd2 = _central_differences(net, V, x.detach())
    for ad, fd in ((first, fd1), (second, fd2)):
        ad, fd = ad.cpu().numpy(), fd.cpu().numpy()
        np.testing.assert_allclose(ad, fd, rtol=1e-5, atol=1e-6 * np.abs(fd).max())
        assert np.abs(fd).max() > 1e-4
    return net, first, second


@pytest.mark.parametrize("kind,d", [(k, d) for k in ("varonet", "fno") for d in (1, 2)])
def test_dde_grad_gives_the_pointwise_derivatives(kind, d):
    net, first, second = _check_derivatives(kind, d)
    # float32: the same network cast down gives the same derivatives to float32 accuracy
    net32 = _net(kind, d)
    net32.load_state_dict(net.state_dict())  # copied into float32 (complex64) tensors
    x = torch.tensor(_points(d, 12 if (kind == "varonet" or d > 1) else 16),
                     dtype=torch.float32).requires_grad_()
    f32, s32 = _dde_derivatives(net32, _sensors(torch.float32), x)
    for lo, hi in ((f32, first), (s32, second)):
        np.testing.assert_allclose(lo.double().numpy(), hi.numpy(), rtol=2e-3,
                                   atol=2e-3 * hi.abs().max().item())


@pytest.mark.gpu
@pytest.mark.skipif(not CUDA, reason="needs a CUDA device")
@pytest.mark.parametrize("kind,d", [(k, d) for k in ("varonet", "fno") for d in (1, 2)])
def test_dde_grad_gives_the_pointwise_derivatives_on_gpu(kind, d, monkeypatch):
    net64, first, second = _check_derivatives(kind, d, device="cuda")
    # float32 on the GPU (TF32 off: it rounds float32 products to 10 mantissa bits): no
    # off-diagonal terms, and DeepXDE's derivatives agree with the float64 ones
    monkeypatch.setattr(torch.backends.cuda.matmul, "allow_tf32", False)
    monkeypatch.setattr(torch.backends.cudnn, "allow_tf32", False)
    net = _net(kind, d).cuda()
    net.load_state_dict(net64.state_dict())
    V = _sensors(torch.float32).cuda()
    x = torch.tensor(_points(d, 12 if (kind == "varonet" or d > 1) else 16),
                     dtype=torch.float32, device="cuda")
    J = torch.autograd.functional.jacobian(lambda x: net((V, x)), x)
    off = ~torch.eye(len(x), dtype=torch.bool, device="cuda")[None, :, None, :, None]
    assert torch.count_nonzero(J[off.expand_as(J)]) == 0
    f32, s32 = _dde_derivatives(net, V, x.requires_grad_())
    for lo, hi in ((f32, first), (s32, second)):
        np.testing.assert_allclose(lo.double().numpy(), hi.numpy(), rtol=2e-3,
                                   atol=2e-3 * hi.abs().max().item())


# ---------------------------------------------------------------- VaRONet options

def test_varonet_query_range_scales_the_coordinates_onto_zero_two():
    with default_float("float64"):
        ref = _net("varonet", 1)
        net = VaRONet(n_sensors=10, hidden_size=6, num_layers=2, latent_dim=3, n_grid=12,
                      query_range=(-3.0, 5.0)).eval()
    net.load_state_dict(ref.state_dict())
    V = _sensors(torch.float64)
    x = torch.tensor([[-3.0], [-1.7], [0.4], [5.0]], dtype=torch.float64)
    with torch.no_grad():
        torch.testing.assert_close(net((V, x)), ref((V, (x + 3) / 8)), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match=r"must lie in \[-3, 5\]; got values from -3 to 6"):
        net((V, torch.tensor([[-3.0], [6.0]], dtype=torch.float64)))


def test_varonet_2d_points_are_decoded_as_sequences_of_their_coordinates():
    with default_float("float64"):
        net = VaRONet(n_sensors=10, hidden_size=6, num_layers=1, latent_dim=3, n_outputs=1,
                      query_dim=2, query_range=[(0, 1), (-1, 1)]).eval()
    V, x = _sensors(torch.float64), torch.tensor([[0.5, 0.0], [0.25, -1.0]],
                                                dtype=torch.float64)
    with torch.no_grad():
        y = net((V, x))
        _, (h, _) = net.encoder(V[..., None])
        state = net.init_states[0](net.mu(h[-1])).view(2, 2, 1, 6)
        for m in range(2):  # point m: the sequence 2 (x - lo) / (hi - lo)
            steps = torch.stack([2 * x[m, 0], x[m, 1] + 1])[None, :, None].expand(2, -1, -1)
            seq, _ = net.decoders[0](steps, (state[:, 0].transpose(0, 1).contiguous(),
                                             state[:, 1].transpose(0, 1).contiguous()))
            torch.testing.assert_close(y[:, m], net.heads[0](seq[:, -1])[:, 0], rtol=0,
                                       atol=1e-13)
    assert y.shape == (2, 2)


def test_varonet_query_coupled_and_its_older_spelling():
    kw = {"hidden_size": 4, "num_layers": 1, "latent_dim": 2}
    assert VaRONet(**kw).query_coupled is False
    assert VaRONet(grid_decoder=False, **kw).query_coupled is True
    assert VaRONet(grid_decoder=True, query_coupled=False, **kw).grid_decoder is True
    coupled = VaRONet(query_coupled=True, query_dim=3, **kw)
    assert coupled.decoders[0].input_size == 3
    with pytest.raises(ValueError, match="grid_decoder=True and query_coupled=True disagree"):
        VaRONet(grid_decoder=True, query_coupled=True, **kw)
    assert VaRONet(regularization=["l2", 1e-5], **kw).regularizer == ["l2", 1e-5]


# ---------------------------------------------------------------- FNO options

def test_fno_2d_reads_its_grid_by_the_tensor_spline():
    with default_float("float64"):
        net = _net("fno", 2, n_outputs=3)
    V = _sensors(torch.float64)
    nodes = torch.tensor(np.linspace(0, 1, 12))
    pts = torch.stack(torch.meshgrid(nodes, nodes, indexing="ij"), -1).reshape(-1, 2)
    with torch.no_grad():
        grid = net.grid_values(V)  # (B, 3, 12, 12)
        y = net((V, pts))
    assert grid.shape == (2, 3, 12, 12) and y.shape == (2, 144, 3)
    torch.testing.assert_close(y, grid.reshape(2, 3, -1).transpose(1, 2), rtol=0, atol=1e-12)


def test_fno_float64_spectral_weights_and_the_grid_shortcut():
    with default_float("float64"):
        net = FNO(n_modes=4, hidden_channels=4, n_layers=1)
    dtypes = {p.dtype for p in net.parameters()}
    assert torch.complex128 in dtypes and dtypes <= {torch.float64, torch.complex128}
    V, t = _sensors(torch.float64, b=3), torch.tensor(np.linspace(0, 2, 100))[:, None]
    with torch.no_grad():
        shortcut = net((torch.cat([V] * 10, 1), t))
    spline = net((torch.cat([V] * 10, 1), t.clone().requires_grad_()))
    torch.testing.assert_close(spline.detach(), shortcut, rtol=0, atol=1e-12)


def test_fno_errors(monkeypatch):
    with pytest.raises(ValueError, match="query_coupled=True is not available"):
        FNO(query_coupled=True)
    net = _net("fno", 2)
    with pytest.raises(ValueError, match=r"coordinate 1 must lie in \[0, 1\]"):
        net((_sensors(torch.float32), torch.tensor([[0.5, 1.5]])))
    monkeypatch.setitem(sys.modules, "neuralop", None)
    monkeypatch.setitem(sys.modules, "neuralop.models", None)
    with pytest.raises(ImportError, match=r'pip install "nh-operators\[fno\]"'):
        FNO()


# ---------------------------------------------------------------- the KL term, training

@pytest.mark.parametrize("n_outputs", [1, 2])
def test_kl_data_adds_beta_kl_to_the_loss_dde_model_computes(n_outputs):
    rng = np.random.default_rng(0)
    V = rng.uniform(size=(5, 10)).astype(np.float32)
    t = np.linspace(0, 1, 7, dtype=np.float32)[:, None]
    y = rng.normal(size=(5, 7, n_outputs) if n_outputs > 1 else (5, 7)).astype(np.float32)
    net = _net("varonet", 1, n_outputs=n_outputs)
    net.noise = torch.zeros_like  # z = μ in training too: the train loss is checkable
    data = KLData(dde.data.TripleCartesianProd((V, t), y, (V, t), y), beta=0.3)
    model = dde.Model(data, net)
    with contextlib.redirect_stdout(io.StringIO()):
        model.compile("adam", lr=1e-3)
        model.train(iterations=0)
    net.eval()
    with torch.no_grad():
        pred = net((torch.tensor(V), torch.tensor(t)))
        mse = torch.mean((pred - torch.tensor(y)) ** 2).item()
        kl = net.kl.item()
    assert kl > 0
    np.testing.assert_allclose(model.train_state.loss_train,
                               [mse, 0.3 * kl / (7 * n_outputs)], rtol=1e-5)
    np.testing.assert_allclose(model.train_state.loss_test,
                               [mse, 0.3 * kl / (7 * n_outputs)], rtol=1e-5)
    with pytest.raises(TypeError, match="KLData needs a network that sets a kl attribute"):
        data.losses_train(torch.tensor(y), pred, torch.nn.functional.mse_loss, None,
                          type("M", (), {"net": _net("fno", 1)})())


@pytest.mark.parametrize("kind", ["varonet", "fno"])
def test_a_short_deepxde_training_on_2d_queries_lowers_the_loss(kind):
    rng = np.random.default_rng(0)
    s = np.linspace(0, 1, 10)
    a, b = rng.uniform(-1, 1, (2, 24, 1))
    V = (a * np.sin(np.pi * s) + b).astype(np.float32)  # f(s) at 10 sensors
    g = np.linspace(0, 1, 6)
    pts = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2).astype(np.float32)
    u = (a * np.sin(np.pi * pts[:, 0]) + b) * pts[:, 1]  # u(x, y) = f(x) y, (24, 36)
    data = dde.data.TripleCartesianProd((V[:16], pts), u[:16].astype(np.float32),
                                        (V[16:], pts), u[16:].astype(np.float32))
    net = _net(kind, 2, n_outputs=1)
    net.train()
    model = dde.Model(data, net)
    with contextlib.redirect_stdout(io.StringIO()):
        model.compile("adam", lr=1e-2)
        history, _ = model.train(iterations=20, display_every=20)
    first, last = history.loss_train[0][0], history.loss_train[-1][0]
    assert np.isfinite(last) and last < 0.7 * first


def test_kl_data_keeps_the_kl_term_in_a_physics_informed_data_object():
    inner = advection_operator_data(10, 3, num_domain=12, num_initial=4)
    data = KLData(inner, beta=2.0)
    net = _net("varonet", 2, n_outputs=1)
    model = dde.Model(data, net)
    with contextlib.redirect_stdout(io.StringIO()):
        model.compile("adam", lr=1e-3)
        model.train(iterations=0)
    V, x = (torch.as_tensor(a, dtype=torch.float32) for a in inner.test_x)
    net.eval()
    with torch.no_grad():
        net((V, x))
    loss = model.train_state.loss_test
    assert len(loss) == 3  # the residual, the initial condition, then the KL column
    np.testing.assert_allclose(loss[-1], 2.0 * net.kl.item() / len(x), rtol=1e-6)


def test_fno_forgets_neuraloperators_cached_grid_after_a_cast():
    # neuraloperator caches its positional grid by resolution only: after a first call in
    # float32, a cast to float64 (or a move to CUDA) must not reuse the old grid
    from nh_operators.models import cast_network

    torch.manual_seed(0)
    net = FNO(hidden_channels=8, n_layers=2, n_modes=8)
    V, t = torch.randn(2, 100), torch.linspace(0, 2, 7)[:, None]
    y32 = net((V, t))
    y64 = cast_network(net, torch.float64)((V.double(), t.double()))
    assert y64.dtype == torch.float64
    assert net.fno.positional_embedding._grid[0].dtype == torch.float64
    torch.testing.assert_close(y64.float(), y32, rtol=1e-5, atol=1e-6)
