"""Decoder and layer options of TraONet and MambONet: queries on their own, pre-norm, GELU."""

import math
import warnings

import numpy as np
import pytest
import torch
from model_helpers import inputs, tiny

import nh_operators as nh
from nh_operators.models import count_parameters


@pytest.mark.parametrize("name", ["traonet", "mambonet"])
@pytest.mark.parametrize("norm_first", [False, True])
def test_without_query_attention_each_time_is_predicted_on_its_own(name, norm_first):
    net = tiny(name, query_attention=False, norm_first=norm_first).eval()
    assert net.query_coupled is False
    V, t = inputs(batch=4, m=9)
    with torch.no_grad():
        together = net((V, t))
        for i in range(len(t)):
            alone = net((V, t[i:i + 1]))
            torch.testing.assert_close(alone[:, 0], together[:, i], rtol=0, atol=2e-6)
        off_grid = torch.cat([t, torch.rand(5, 1) * 2])  # other company, off-grid times
        torch.testing.assert_close(net((V, off_grid))[:, :len(t)], together,
                                   rtol=0, atol=2e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # predict does not warn for such a network
        q, _ = nh.predict(net, V.numpy(), np.array([0.3, 1.7]))
    assert q.shape == (4, 2)


@pytest.mark.parametrize("name", ["traonet", "mambonet"])
def test_the_papers_decoder_couples_the_queries(name):
    net = tiny(name).eval()
    assert net.query_coupled is True
    V, t = inputs(batch=2, m=9)
    with torch.no_grad():
        gap = (net((V, t[:1]))[:, 0] - net((V, t))[:, 0]).abs().max()
    assert gap > 1e-4  # self-attention over the queries: the company matters
    # predict runs a coupled network on the training grid, so company does not matter
    alone, _ = nh.predict(net, V.numpy(), np.array([0.3]))
    among, _ = nh.predict(net, V.numpy(), np.array([0.3, 1.7]))
    np.testing.assert_array_equal(alone[:, 0], among[:, 0])


def test_pre_norm_adds_the_final_norms_and_gelu_changes_the_output():
    plain, pre = tiny("traonet"), tiny("traonet", norm_first=True)
    d = 16  # TINY's d_model: one LayerNorm (2d) after the encoder, one before the head
    assert count_parameters(pre) == count_parameters(plain) + 2 * (2 * d)
    relu, gelu = tiny("traonet", seed=3).eval(), tiny("traonet", seed=3, activation="gelu")
    gelu.load_state_dict(relu.state_dict())
    with torch.no_grad():
        assert not torch.allclose(relu(inputs()), gelu.eval()(inputs()))
    with pytest.raises(ValueError, match="activation must be 'relu' or 'gelu'"):
        tiny("traonet", activation="tanh")
    with pytest.raises(ValueError, match="activation must be 'relu' or 'gelu'"):
        tiny("mambonet", activation="tanh", query_attention=False)


def test_default_layout_keeps_the_shipped_state_dict_keys():
    keys = set(tiny("traonet").state_dict())
    assert any(k.startswith("decoder.decoder.layers.0.self_attn") for k in keys)
    assert not any("final_norm" in k or k.startswith("encoder.norm") for k in keys)


@pytest.mark.parametrize("name", ["traonet", "mambonet"])
def test_scaled_outputs_is_an_affine_map_of_the_same_head(name):
    """scaled_outputs=True: same parameters, q = 0.5 + 0.5 y_q, p = sqrt(8) y_p."""
    V = torch.randn(3, 100, generator=torch.Generator().manual_seed(1))
    t = torch.linspace(0, 2, 7)[:, None]
    nets = []
    for scaled in (False, True):
        torch.manual_seed(0)
        nets.append(tiny(name, scaled_outputs=scaled))
    assert list(nets[0].state_dict()) == list(nets[1].state_dict())
    with torch.no_grad():
        plain, scaled = nets[0]((V, t)), nets[1]((V, t))
    torch.testing.assert_close(scaled[..., 0], 0.5 + 0.5 * plain[..., 0])
    torch.testing.assert_close(scaled[..., 1], math.sqrt(8.0) * plain[..., 1])
    with pytest.raises(ValueError, match="scaled_outputs needs n_outputs = 2"):
        tiny(name, n_outputs=1, scaled_outputs=True)
