"""Networks that read a starting state (q0, p0) after the sensors (issue 26): the option
leaves today's networks as they are, reads the state, and trains on a dataset of states."""

import numpy as np
import pytest
import torch
from model_helpers import TINY, inputs, tiny

import nh_operators as nh
from nh_operators.data import H5Rows, generate_dataset

STATEFUL = ["deeponet", "fno", "mambonet", "traonet", "varonet"]


def _with_state(V, q0=0.3, p0=-0.5):
    state = torch.tensor([[q0, p0]], dtype=V.dtype).expand(V.shape[0], -1)
    return torch.cat([V, state], dim=1)


@pytest.mark.parametrize("name", STATEFUL)
def test_the_option_off_is_todays_network(name):
    plain, off = tiny(name, seed=4), tiny(name, seed=4, initial_state=False)
    assert plain.state_dict().keys() == off.state_dict().keys()
    for key, value in plain.state_dict().items():
        assert torch.equal(value, off.state_dict()[key]), key
    V, t = inputs()
    plain.eval(), off.eval()
    with torch.no_grad():
        assert torch.equal(plain((V, t)), off((V, t)))


@pytest.mark.parametrize("name", STATEFUL)
def test_a_stateful_network_reads_the_state(name):
    net = tiny(name, seed=5, initial_state=True).eval()
    V, t = inputs(batch=4)
    x = _with_state(V).requires_grad_(True)
    y = net((x, t))
    assert y.shape == (4, t.shape[0], 2)
    (grad,) = torch.autograd.grad(y.sum(), x)
    # the output depends on q0 and on p0 of its own row only
    assert torch.all(grad[:, 100:].abs().sum(dim=0) > 0)
    with torch.no_grad():
        moved = net((_with_state(V, q0=0.6), t))
    assert not torch.allclose(moved, y.detach())
    # rows do not mix: changing row 0's state leaves row 1
    x2 = _with_state(V).clone()
    x2[0, 100] = 0.9
    with torch.no_grad():
        np.testing.assert_allclose(net((x2, t))[1].numpy(), y[1].detach().numpy(),
                                   rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", STATEFUL)
def test_the_wrong_width_is_named(name):
    V, t = inputs()
    with pytest.raises(ValueError, match=r"V must have shape \(batch, 102\) \(100 sensors, "
                                         r"then q0 and p0"):
        tiny(name, initial_state=True)((V, t))
    with pytest.raises(ValueError, match=r"a network built with initial_state=True reads"):
        tiny(name)((_with_state(V), t))


@pytest.mark.parametrize("name", ["traonet", "mambonet"])
def test_state_in_queries_reaches_every_time_token(name):
    net = tiny(name, seed=5, initial_state=True, state_in_queries=True).eval()
    base = tiny(name, seed=5, initial_state=True).eval()
    assert set(net.state_dict()) - set(base.state_dict()) == {
        "query_state.embed.weight", "query_state.embed.bias"}
    V, t = inputs(batch=2)
    x = _with_state(V).requires_grad_(True)
    (grad,) = torch.autograd.grad(net((x, t))[:, 0].sum(), x)
    assert torch.all(grad[:, 100:] != 0)
    with pytest.raises(ValueError, match="state_in_queries needs initial_state=True"):
        tiny(name, state_in_queries=True)


@pytest.fixture(scope="module")
def states_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("states") / "s.h5"
    generate_dataset(100, seed=3, path=path, progress=False, states="energy")
    return path


def test_rows_of_a_states_file_are_the_network_input(states_file):
    rows, ds = H5Rows(states_file), nh.load_dataset(states_file)
    assert rows.states
    V, q, p = rows.read([5, 2])
    np.testing.assert_array_equal(V, ds.branch_input()[[5, 2]])
    assert V.shape == (2, 102)


def test_a_stateful_network_trains_on_states_and_a_mismatch_is_named(states_file, tmp_path):
    cfg = nh.TrainConfig("traonet", preset="cpu", arch={**TINY["traonet"], "initial_state": True},
                         epochs=6, seed=7, batch_size=20, lr=1e-2, infimum_lr=1e-3)
    net, history = nh.train(cfg, states_file, tmp_path / "a", progress=False)
    assert history[-1]["train_loss"] < 0.85 * history[0]["train_loss"]
    plain = nh.TrainConfig("traonet", preset="cpu", arch=TINY["traonet"], epochs=1)
    with pytest.raises(ValueError, match="add --arch initial_state=True"):
        nh.train(plain, states_file, tmp_path / "b", progress=False)
    rest = generate_dataset(20, seed=1, progress=False)
    with pytest.raises(ValueError, match="generate one with --states energy"):
        nh.train(cfg, rest, tmp_path / "c", progress=False)
