"""The networks: shapes for any M, dtypes, DeepXDE transforms, state_dict, registry."""

import numpy as np
import pytest
import torch
from model_helpers import inputs, tiny

import nh_operators as nh
from nh_operators.models import DeepONet, cast_network, model_config

from nh_operators._backend import ensure_pytorch_backend  # noqa: E402
deepxde = ensure_pytorch_backend()


@pytest.mark.parametrize("name", sorted(nh.MODELS))
@pytest.mark.parametrize("m", [1, 7, 100])
def test_output_shape_for_any_number_of_times(name, m):
    net = tiny(name).eval()
    y = net(inputs(batch=3, m=m))
    assert y.shape == (3, m, 2)
    assert torch.all(torch.isfinite(y))


@pytest.mark.parametrize("name", sorted(nh.MODELS))
def test_float64_and_state_dict_round_trip(name):
    net = cast_network(tiny(name, seed=0), torch.float64).eval()
    x = inputs(dtype=torch.float64)
    y = net(x)
    assert y.dtype == torch.float64
    other = cast_network(tiny(name, seed=5), torch.float64).eval()
    assert not torch.allclose(other(x), y)
    other.load_state_dict(net.state_dict(), strict=True)
    assert torch.equal(other(x), y)


@pytest.mark.parametrize("name", sorted(nh.MODELS))
def test_deepxde_transforms_are_applied(name):
    net = tiny(name).eval()
    V, t = inputs()
    y = net((V, t))
    net.apply_output_transform(lambda x, out: 3.0 * out + x[0][:, :1, None])
    assert torch.allclose(net((V, t)), 3.0 * y + V[:, :1, None], atol=1e-6)
    # the feature transform acts on t (as in DeepXDE's DeepONetCartesianProd)
    net.apply_output_transform(None)
    zero = net((V, torch.zeros_like(t)))
    net.apply_feature_transform(lambda tt: torch.zeros_like(tt))
    assert torch.allclose(net((V, t)), zero, atol=1e-6)


@pytest.mark.parametrize("name", sorted(nh.MODELS))
def test_single_output_drops_the_last_axis(name):
    net = tiny(name, n_outputs=1).eval()
    assert net(inputs(batch=2, m=5)).shape == (2, 5)


@pytest.mark.parametrize("name", sorted(nh.MODELS))
def test_bad_input_shapes_are_named(name):
    net = tiny(name)
    V, t = inputs()
    with pytest.raises(ValueError, match=r"V must have shape \(batch, 100\)"):
        net((V[:, :50], t))
    with pytest.raises(ValueError, match=r"query points must have shape \(M, 1\)"):
        net((V, t[:, 0]))
    with pytest.raises(ValueError, match="pair"):
        net(V)


def test_varonet_is_deterministic_in_eval_mode_only():
    net = tiny("varonet")
    x = inputs()
    net.eval()
    assert torch.equal(net(x), net(x))
    kl_eval = net.kl
    net.train()
    assert not torch.equal(net(x), net(x))
    # KL(N(μ, σ²) ‖ N(0, I)) from the heads, by hand
    with torch.no_grad():
        _, (h, _) = net.encoder(x[0][..., None])
        mu, logvar = net.mu(h[-1]), net.logvar(h[-1])
        kl = 0.5 * (mu**2 + logvar.exp() - 1 - logvar).sum(-1).mean()
    assert kl_eval.item() == pytest.approx(kl.item(), rel=1e-6)


def test_deeponet_is_deepxdes_own_and_counts_match_the_layout():
    net = nh.build_model("deeponet", "paper")
    assert isinstance(net, deepxde.nn.pytorch.DeepONetCartesianProd)
    hidden = 128 * 128 + 128
    branch = (100 * 128 + 128) + 2 * hidden + (128 * 20 + 20)
    trunk = (1 * 128 + 128) + 2 * hidden + (128 * 20 + 20)
    assert nh.count_parameters(net) == branch + trunk + 2  # + one bias per output


def test_traonet_paper_preset_counts_match_the_layout():
    net = nh.build_model("traonet", "paper")
    d, ff, layers = 64, 512, 3
    attn = 4 * d * d + 4 * d
    ffn = d * ff + ff + ff * d + d
    encoder = layers * (attn + ffn + 2 * 2 * d)
    decoder = layers * (2 * attn + ffn + 3 * 2 * d)
    embeds = 2 * (d + d)
    assert nh.count_parameters(net) == encoder + decoder + embeds + (2 * d + 2)


def test_fno_reads_the_standard_grid_exactly_and_rejects_late_times():
    net = tiny("fno").eval()
    V, _ = inputs()
    t = torch.linspace(0, 2, 100)[:, None]
    raw = net.fno(V[:, None, :], output_shape=(100,)).transpose(1, 2)
    assert torch.allclose(net((V, t)), raw, atol=1e-6)
    with pytest.raises(ValueError, match="query times"):
        net((V, torch.tensor([[2.5]])))


def test_cast_network_keeps_complex_spectral_weights():
    net = tiny("fno")
    weights = [p for p in net.parameters() if p.is_complex()]
    assert weights and all(p.imag.abs().max() > 0 for p in weights)
    before = [p.detach().clone() for p in weights]
    cast_network(net, torch.float64)
    after = [p for p in net.parameters() if p.is_complex()]
    assert all(p.dtype == torch.complex128 for p in after)
    assert all(torch.allclose(a.to(torch.complex128), b) for a, b in zip(before, after))


def test_registry_errors_name_the_problem():
    with pytest.raises(ValueError, match="unknown model 'bert'"):
        nh.build_model("bert")
    with pytest.raises(ValueError, match="unknown preset 'huge'"):
        nh.build_model("traonet", "huge")
    with pytest.raises(ValueError, match=r"no argument\(s\) \['width'\]"):
        nh.build_model("traonet", width=3)
    assert model_config("traonet", "paper", nhead=4)["nhead"] == 4


def test_paper_presets_follow_the_paper_table():
    assert model_config("traonet", "paper") == dict(
        d_model=64, nhead=8, num_layers=3, dim_feedforward=512)
    assert model_config("varonet", "paper") == dict(
        hidden_size=512, num_layers=4, latent_dim=30)
    assert model_config("mambonet", "paper")["num_mamba_layers"] == 4
    assert isinstance(nh.build_model("deeponet", "cpu"), DeepONet)
    assert np.isclose(nh.models.training_defaults("varonet")["beta"], 5.4963e-2)
