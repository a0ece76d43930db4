"""A light PhaseONet's CPU inference runs torch on one thread; numba's count and every
other network's torch count are left as set, and restored counts are the caller's."""

import numba
import numpy as np
import pytest
import torch

import nh_operators as nh
from nh_operators._backend import torch_threads
from nh_operators.models.phaseonet import LIGHT_TORCH_MACS, PhaseONet


@pytest.fixture
def two_threads():
    """torch and numba at two threads for the test (the machine's count), restored."""
    before = torch.get_num_threads(), numba.get_num_threads()
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread here")
    torch.set_num_threads(2)
    numba.set_num_threads(2)
    yield
    torch.set_num_threads(before[0])
    numba.set_num_threads(before[1])


def _threads_in_forward(net: torch.nn.Module, rows: int) -> tuple[list[int], list[int]]:
    """torch's and numba's thread counts seen inside each forward of nh.predict."""
    seen_torch, seen_numba = [], []

    def hook(module, args):
        seen_torch.append(torch.get_num_threads())
        seen_numba.append(numba.get_num_threads())

    handle = net.register_forward_pre_hook(hook)
    try:
        V = 2 - 8 * nh.SENSORS * (1 - nh.SENSORS)
        nh.predict(net, np.tile(V, (rows, 1)), nh.TIMES, batch_size=300)
    finally:
        handle.remove()
    return seen_torch, seen_numba


def test_macs_per_row_decide_it() -> None:
    tiny = PhaseONet(width=16, depth=1, basis=4, grid=128, shape="quadrature")
    # branch 101·16 + 16 + 16·8 + 8 weights and biases, basis 2 · 4 · 128
    assert sum(p.numel() for p in tiny.branch.parameters()) + tiny.basis.numel() == 2792
    assert tiny.cpu_torch_threads == 1
    assert PhaseONet().cpu_torch_threads == 1           # 54,208 multiply-adds
    assert PhaseONet(width=256, depth=3).cpu_torch_threads is None   # 190,528
    assert 54_208 < LIGHT_TORCH_MACS < 190_528
    assert nh.pretrained("phaseonet-alg1-quadrature").net.cpu_torch_threads == 1
    # a network from a state, and other architectures, have no such count
    assert not hasattr(nh.pretrained("phaseonet-alg1-states").net, "cpu_torch_threads")
    assert not hasattr(nh.build_model("deeponet", preset="cpu"), "cpu_torch_threads")


@pytest.mark.usefixtures("two_threads")
def test_a_light_phaseonet_runs_torch_on_one_thread_and_numba_on_its_own() -> None:
    net = PhaseONet(width=16, depth=1, basis=4, grid=16, shape="quadrature")
    seen_torch, seen_numba = _threads_in_forward(net, 700)  # three batches of ≤ 300
    assert seen_torch == [1, 1, 1] and seen_numba == [2, 2, 2]
    assert torch.get_num_threads() == 2 and numba.get_num_threads() == 2


@pytest.mark.usefixtures("two_threads")
def test_heavy_networks_keep_torchs_count() -> None:
    for net in (PhaseONet(width=256, depth=3, grid=16),
                nh.build_model("deeponet", preset="cpu")):
        seen_torch, _ = _threads_in_forward(net, 300)
        assert seen_torch == [2]


@pytest.mark.usefixtures("two_threads")
def test_the_count_is_restored_when_the_forward_raises() -> None:
    net = PhaseONet(width=16, depth=1, basis=4, grid=16)

    def fail(module, args):
        raise RuntimeError("inside the forward")

    handle = net.register_forward_pre_hook(fail)
    try:
        with pytest.raises(RuntimeError, match="inside the forward"):
            nh.predict(net, np.tile(2 - 8 * nh.SENSORS * (1 - nh.SENSORS), (3, 1)),
                       nh.TIMES)
    finally:
        handle.remove()
    assert torch.get_num_threads() == 2


def test_torch_threads_none_and_same_count_change_nothing() -> None:
    before = torch.get_num_threads()
    with torch_threads(None):
        assert torch.get_num_threads() == before
    with torch_threads(before):
        assert torch.get_num_threads() == before
    assert torch.get_num_threads() == before
