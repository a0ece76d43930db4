"""VaRONet's ``encoder_cell`` option: the decoders start from the encoder's cell states,
a deterministic path beside the latent (as in the reference code behind the paper)."""

import numpy as np
import pytest
import torch

from nh_operators.models import VaRONet


def _net(encoder_cell, grid_decoder=False):
    torch.manual_seed(0)
    return VaRONet(hidden_size=8, num_layers=2, latent_dim=3, encoder_cell=encoder_cell,
                   grid_decoder=grid_decoder).eval()


def _inputs():
    g = torch.Generator().manual_seed(1)
    return torch.rand(4, 100, generator=g), torch.linspace(0, 2, 7)[:, None]


def test_encoder_cell_forward_by_hand():
    net = _net(True)
    V, t = _inputs()
    with torch.no_grad():
        _, (h, c) = net.encoder(V[..., None])
        z = net.mu(h[-1])
        outs = []
        for init, decoder, head in zip(net.init_states, net.decoders, net.heads):
            h0 = init(z).view(4, 2, 8).transpose(0, 1).contiguous()
            seq, _ = decoder(t[None].expand(4, -1, -1), (h0, c))
            outs.append(head(seq))
        expected = torch.cat(outs, -1)
        torch.testing.assert_close(net((V, t)), expected, rtol=0, atol=0)
    # the maps of z give h only: half the parameters of the default's
    assert net.init_states[0].out_features == 2 * 8
    assert _net(False).init_states[0].out_features == 2 * 2 * 8


def test_only_the_encoder_cell_carries_v_past_a_silenced_latent():
    V, t = _inputs()
    for encoder_cell, differs in ((False, False), (True, True)):
        net = _net(encoder_cell)
        with torch.no_grad():  # z = μ = 0 whatever V is
            net.mu.weight.zero_()
            net.mu.bias.zero_()
            y = net((V, t))
        assert bool((y[0] - y[1]).abs().max() > 1e-6) is differs


def test_grid_decoder_predictions_do_not_depend_on_the_other_times_asked():
    from scipy.interpolate import CubicSpline

    from nh_operators import TIMES

    net = _net(True, grid_decoder=True).double()
    assert net.query_coupled is False
    V = _inputs()[0].double()
    grid = torch.tensor(TIMES)[:, None]
    with torch.no_grad():
        full = net((V, grid))
        # a grid time alone, or among others, is the grid call's value
        np.testing.assert_allclose(net((V, grid[[37]]))[:, 0], full[:, 37], rtol=0,
                                   atol=1e-12)
        np.testing.assert_allclose(net((V, grid[[99, 3, 50]])), full[:, [99, 3, 50]],
                                   rtol=0, atol=1e-12)
        # off the grid: the cubic spline through the grid outputs
        t = torch.tensor([[0.013], [1.2345], [1.999]], dtype=torch.float64)
        expected = CubicSpline(TIMES, full.numpy(), axis=1)(t[:, 0].numpy())
        np.testing.assert_allclose(net((V, t)).numpy(), expected, rtol=0, atol=1e-12)
        alone = net((V, t[1:2]))
    np.testing.assert_allclose(alone.numpy(), expected[:, 1:2], rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match=r"must lie in \[0, 2\]; got values from 0 to 2.5"):
        net((V, torch.tensor([[0.0], [2.5]], dtype=torch.float64)))


def test_without_the_grid_the_decoders_read_the_asked_times():
    net = VaRONet(hidden_size=8, num_layers=1, latent_dim=3, grid_decoder=False).eval()
    assert net.query_coupled is True
    V, t = _inputs()
    with torch.no_grad():
        both = net((V, t))
        assert not torch.allclose(net((V, t[3:4]))[:, 0], both[:, 3])
