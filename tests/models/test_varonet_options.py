"""VaRONet's ``encoder_cell`` option: the decoders start from the encoder's cell states,
a deterministic path beside the latent (as in the reference code behind the paper)."""

import torch

from nh_operators.models import VaRONet


def _net(encoder_cell):
    torch.manual_seed(0)
    return VaRONet(hidden_size=8, num_layers=2, latent_dim=3,
                   encoder_cell=encoder_cell).eval()


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
