"""The pure-PyTorch Mamba block and its custom selective scan."""

import sys

import pytest
import torch

from nh_operators.models._scan import selective_scan, selective_scan_reference
from nh_operators.models.mamba import Mamba, cuda_kernel_available


def scan_inputs(batch, length, d_inner, d_state, dtype, seed=0, requires_grad=True):
    g = torch.Generator().manual_seed(seed)
    u = torch.randn(batch, length, d_inner, generator=g, dtype=dtype)
    delta = torch.nn.functional.softplus(torch.randn(batch, length, d_inner, generator=g,
                                                     dtype=dtype) - 1)
    A = -torch.exp(torch.randn(d_inner, d_state, generator=g, dtype=dtype))
    B = torch.randn(batch, length, d_state, generator=g, dtype=dtype)
    C = torch.randn(batch, length, d_state, generator=g, dtype=dtype)
    return [t.requires_grad_(requires_grad) for t in (u, delta, A, B, C)]


def rel_err(a, b):
    return ((a - b).abs().max() / b.abs().max().clamp_min(torch.finfo(b.dtype).tiny)).item()


# ------------------------------------------------------------------ selective scan


def test_scan_gradcheck():
    inputs = scan_inputs(2, 7, 3, 4, torch.float64)
    assert torch.autograd.gradcheck(selective_scan, inputs)


@pytest.mark.parametrize("dtype, tol", [(torch.float64, 1e-12), (torch.float32, 1e-5)])
def test_scan_matches_reference(dtype, tol):
    inputs = scan_inputs(4, 40, 16, 8, dtype, seed=1)
    y = selective_scan(*inputs)
    y_ref = selective_scan_reference(*inputs)
    assert y.shape == (4, 40, 16) and y.dtype == dtype
    assert rel_err(y, y_ref) < tol
    gy = torch.randn(y.shape, generator=torch.Generator().manual_seed(2), dtype=dtype)
    grads = torch.autograd.grad(y, inputs, gy)
    grads_ref = torch.autograd.grad(y_ref, inputs, gy)
    for name, g, g_ref in zip("u delta A B C".split(), grads, grads_ref):
        assert g.shape == g_ref.shape, name
        assert rel_err(g, g_ref) < tol, name


@pytest.mark.parametrize("length", [1, 2, 3, 4, 10, 11, 26])
def test_scan_lengths(length):
    """Every length cuts time differently into checkpointed chunks."""
    inputs = scan_inputs(2, length, 3, 4, torch.float64, seed=length)
    y = selective_scan(*inputs)
    y_ref = selective_scan_reference(*inputs)
    assert rel_err(y, y_ref) < 1e-12
    gy = torch.randn(y.shape, generator=torch.Generator().manual_seed(7), dtype=y.dtype)
    for g, g_ref in zip(torch.autograd.grad(y, inputs, gy),
                        torch.autograd.grad(y_ref, inputs, gy)):
        assert rel_err(g, g_ref) < 1e-12


def test_scan_partial_grads():
    u, delta, A, B, C = scan_inputs(2, 9, 5, 3, torch.float64, seed=3)
    A.requires_grad_(False)
    C.requires_grad_(False)
    y = selective_scan(u, delta, A, B, C)
    grads = torch.autograd.grad(y.sum(), (u, delta, B))
    grads_ref = torch.autograd.grad(selective_scan_reference(u, delta, A, B, C).sum(),
                                    (u, delta, B))
    for g, g_ref in zip(grads, grads_ref):
        assert rel_err(g, g_ref) < 1e-12


def test_scan_no_grad_equals_grad_mode():
    inputs = scan_inputs(3, 11, 6, 4, torch.float32, seed=4)
    with torch.no_grad():
        y0 = selective_scan(*inputs)
    assert not y0.requires_grad
    torch.testing.assert_close(y0, selective_scan(*inputs).detach(), rtol=0, atol=0)


def test_scan_rejects_bad_shapes():
    u, delta, A, B, C = scan_inputs(2, 5, 3, 4, torch.float32, requires_grad=False)
    with pytest.raises(ValueError):
        selective_scan(u, delta, A.T, B, C)
    with pytest.raises(ValueError):
        selective_scan(u, delta, A, B, C.double())


# ------------------------------------------------------------------ Mamba block


def expected_keys(d_model, bias=False, d_state=16, d_conv=4, expand=2):
    d_inner = expand * d_model
    dt_rank = -(-d_model // 16)
    keys = {
        "in_proj.weight": (2 * d_inner, d_model),
        "conv1d.weight": (d_inner, 1, d_conv),
        "conv1d.bias": (d_inner,),
        "x_proj.weight": (dt_rank + 2 * d_state, d_inner),
        "dt_proj.weight": (d_inner, dt_rank),
        "dt_proj.bias": (d_inner,),
        "A_log": (d_inner, d_state),
        "D": (d_inner,),
        "out_proj.weight": (d_model, d_inner),
    }
    if bias:
        keys.update({"in_proj.bias": (2 * d_inner,), "out_proj.bias": (d_model,)})
    return keys


@pytest.mark.parametrize("bias", [False, True])
def test_state_dict_matches_mamba_ssm(bias):
    torch.manual_seed(0)
    block = Mamba(32, bias=bias)
    assert (block.d_inner, block.dt_rank) == (64, 2)
    shapes = {k: tuple(v.shape) for k, v in block.state_dict().items()}
    assert shapes == expected_keys(32, bias=bias)
    assert block.x_proj.weight.shape[0] == 34
    assert block.A_log.dtype == block.D.dtype == torch.float32
    assert block.A_log._no_weight_decay and block.D._no_weight_decay
    torch.testing.assert_close(block.A_log[5].exp(), torch.arange(1.0, 17.0))
    torch.testing.assert_close(block.D, torch.ones(64))
    dt = torch.nn.functional.softplus(block.dt_proj.bias)
    assert dt.min() >= 1e-3 * 0.999 and dt.max() <= 0.1 * 1.001
    assert block.dt_proj.weight.abs().max() <= 2 ** -0.5
    assert list(block.buffers()) == []


def test_state_dict_round_trip():
    torch.manual_seed(1)
    block = Mamba(32)
    with torch.no_grad():  # move D away from its initial value so it matters
        block.D.add_(torch.randn(64))
    torch.manual_seed(2)
    fresh = Mamba(32)
    fresh.load_state_dict(block.state_dict(), strict=True)
    x = torch.randn(3, 20, 32)
    torch.testing.assert_close(fresh(x), block(x), rtol=0, atol=0)


def test_causal():
    torch.manual_seed(3)
    block = Mamba(16, d_state=8).double()
    x = torch.randn(2, 25, 16, dtype=torch.float64)
    y = block(x)
    for k in (0, 7, 24):
        x2 = x.clone()
        x2[:, k] += torch.randn(2, 16, dtype=torch.float64)
        y2 = block(x2)
        torch.testing.assert_close(y2[:, :k], y[:, :k], rtol=0, atol=0)
        assert (y2[:, k] - y[:, k]).abs().max() > 1e-6


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
@pytest.mark.parametrize("length", [1, 3, 4, 17, 64])
def test_output_shape(dtype, length):
    torch.manual_seed(4)
    block = Mamba(16, d_state=4, d_conv=4).to(dtype)
    x = torch.randn(2, length, 16, dtype=dtype, requires_grad=True)
    y = block(x)
    assert y.shape == (2, length, 16) and y.dtype == dtype
    y.square().mean().backward()
    assert x.grad.shape == x.shape
    assert all(p.grad is not None for p in block.parameters())


def test_block_gradients_match_reference_scan(monkeypatch):
    torch.manual_seed(5)
    block = Mamba(16, d_state=4).double()
    x = torch.randn(2, 12, 16, dtype=torch.float64)
    block(x).square().sum().backward()
    grads = {n: p.grad.clone() for n, p in block.named_parameters()}
    block.zero_grad()
    import nh_operators.models.mamba as mamba_module
    monkeypatch.setattr(mamba_module, "selective_scan", selective_scan_reference)
    block(x).square().sum().backward()
    for n, p in block.named_parameters():
        assert rel_err(grads[n], p.grad) < 1e-12, n


def test_no_grad_forward():
    torch.manual_seed(6)
    block = Mamba(32)
    x = torch.randn(4, 30, 32)
    y = block(x)
    assert y.requires_grad
    with torch.no_grad():
        y0 = block(x)
    assert not y0.requires_grad
    torch.testing.assert_close(y0, y.detach(), rtol=0, atol=0)


def test_no_cuda_kernel_here():
    assert cuda_kernel_available() is False


def test_import_does_not_load_mamba_ssm():
    import nh_operators.models.mamba as mamba_module

    mamba_module.Mamba(16)(torch.zeros(1, 3, 16))
    cuda_kernel_available()
    assert "mamba_ssm" not in sys.modules
