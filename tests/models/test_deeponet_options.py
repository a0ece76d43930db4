"""DeepONet's initialisation and trunk-output options (issue 13's DeepONet check)."""

import math

import pytest
import torch

from nh_operators.models import DeepONet


def _linears(net):
    return [m for m in net.modules() if isinstance(m, torch.nn.Linear)]


def test_deepxde_initialisation_has_zero_biases_and_glorot_scale():
    torch.manual_seed(0)
    net = DeepONet(hidden_size=256, hidden_layers=2, branches=64)
    for layer in _linears(net):
        assert torch.count_nonzero(layer.bias) == 0
        fan_out, fan_in = layer.weight.shape
        std = layer.weight.std().item()
        assert std == pytest.approx(math.sqrt(2 / (fan_in + fan_out)), rel=0.1)


def test_torch_initialisation_is_uniform_in_one_over_root_fan_in():
    torch.manual_seed(0)
    net = DeepONet(hidden_size=256, hidden_layers=2, branches=64, initializer="torch")
    for layer in _linears(net):
        bound = 1 / math.sqrt(layer.weight.shape[1])
        assert layer.weight.abs().max().item() <= bound
        assert layer.weight.abs().max().item() > 0.9 * bound
        assert layer.bias.abs().max().item() <= bound
        assert torch.count_nonzero(layer.bias) == layer.bias.numel()
        # a uniform on [-b, b] has std b/√3
        assert layer.weight.std().item() == pytest.approx(bound / math.sqrt(3), rel=0.1)


@pytest.mark.parametrize("trunk_output_activation", [True, False])
def test_output_is_the_split_inner_product_of_branch_and_trunk(trunk_output_activation):
    torch.manual_seed(1)
    net = DeepONet(hidden_size=8, hidden_layers=2, branches=3,
                   trunk_output_activation=trunk_output_activation).eval()
    with torch.no_grad():
        for b in net.b:
            b.fill_(0.25)
        V, t = torch.randn(4, 100), torch.linspace(0, 2, 7)[:, None]
        branch, trunk = net.branch(V), net.trunk(t)
        if trunk_output_activation:
            trunk = torch.nn.functional.gelu(trunk)
        want = torch.stack([branch[:, :3] @ trunk[:, :3].T + 0.25,
                            branch[:, 3:] @ trunk[:, 3:].T + 0.25], dim=2)
        torch.testing.assert_close(net((V, t)), want, rtol=1e-6, atol=1e-6)
    assert net.trunk_output_activation is trunk_output_activation


def test_default_state_dict_keys_do_not_depend_on_the_options():
    keys = set(DeepONet(hidden_size=8, hidden_layers=2, branches=3).state_dict())
    other = DeepONet(hidden_size=8, hidden_layers=2, branches=3, initializer="torch",
                     trunk_output_activation=False)
    assert set(other.state_dict()) == keys
