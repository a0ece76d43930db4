"""CUDA checks (skipped without a GPU): same results as on the CPU, training, AMP."""

import numpy as np
import pytest
import torch
from model_helpers import TINY, inputs, tiny

import nh_operators as nh
from nh_operators.data import generate_dataset
from nh_operators.models import mamba

pytestmark = pytest.mark.gpu


@pytest.mark.parametrize("name", sorted(nh.MODELS))
def test_cuda_forward_matches_cpu(name):
    net = tiny(name).eval()
    x = inputs()
    with torch.no_grad():
        cpu = net(x)
        gpu = net.cuda()(tuple(a.cuda() for a in x)).cpu()
    assert torch.allclose(cpu, gpu, atol=1e-4)


@pytest.mark.parametrize("name", ["deeponet", "mambonet", "traonet", "varonet"])
def test_cuda_forward_matches_cpu_for_the_reference_variants(name):
    arch = dict(hidden_size=16, branches=4) if name == "deeponet" else TINY[name]
    torch.manual_seed(0)
    net = nh.build_model(name, "cpu", variant="reference", **arch).eval()
    x = inputs()
    with torch.no_grad():
        cpu = net(x)
        gpu = net.cuda()(tuple(a.cuda() for a in x)).cpu()
    assert torch.allclose(cpu, gpu, atol=1e-4)


def test_state_network_on_cuda_matches_cpu():
    net = tiny("phaseonet", initial_state=True).eval()
    V, t = inputs(batch=2)
    V = torch.cat([0.5 * torch.cos(6 * torch.linspace(0, 1, 100)).expand(2, 100) + 1,
                   torch.tensor([[0.3, 0.2], [0.5, -0.4]])], dim=1)
    with torch.no_grad():
        cpu = net((V, t))
        gpu = net.cuda()((V.cuda(), t.cuda())).cpu()
    assert torch.isfinite(cpu).all() and torch.allclose(cpu, gpu, atol=1e-4)


def test_default_device_is_left_alone():
    assert torch.get_default_device().type == "cpu"


def test_mamba_cuda_kernel_agrees_with_the_cpu_scan_when_installed():
    block = mamba.Mamba(32).eval()
    x = torch.randn(2, 50, 32)
    with torch.no_grad():
        cpu = block(x)
        gpu = block.cuda()(x.cuda()).cpu()
    if not mamba.cuda_kernel_available():
        pytest.skip("mamba_ssm is not installed: the CPU scan ran on the GPU")
    assert torch.allclose(cpu, gpu, atol=1e-4)


@pytest.mark.parametrize("amp", [False, True])
def test_training_on_cuda(amp, tmp_path):
    data = generate_dataset(60, seed=1, progress=False)
    config = nh.TrainConfig("traonet", arch=TINY["traonet"], epochs=2, batch_size=20,
                            device="cuda", amp=amp)
    net, history = nh.train(config, data, tmp_path, progress=False)
    assert next(net.parameters()).is_cuda
    assert np.isfinite(history[-1]["val_loss"])
    assert torch.get_default_device().type == "cpu"


def test_timing_on_cuda_synchronises_and_names_the_gpu():
    from nh_operators.evaluation import device_info, seconds_per_trajectory

    method = nh.NeuralMethod(tiny("traonet").cuda(), "traonet", domain_check=False)
    calls = []
    sync = method.synchronize
    method.synchronize = lambda: calls.append(1) or sync()
    V = np.tile(nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS), (16, 1))
    r = seconds_per_trajectory(method, V, nh.TIMES, n_single=2, repeats=2)
    assert method.device.startswith("cuda") and r["batch_1"] > 0 and r["batched"] > 0
    assert len(calls) == 2 * 3 + 3  # before the clock and after every timed call
    assert device_info(method.device)["device"].startswith("cuda: ")
