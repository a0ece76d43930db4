"""Training and inference throughput of every network and preset on this machine.

    python benchmarks/cost/model_throughput.py [--models traonet,mambonet] [--presets cpu]
                                          [--device cpu|cuda] [--repeats 5]

Training: DeepXDE's own compiled step (``dde.Model.train_step``: forward, loss,
backward, AdamW update) at batch 100 on the 100-time grid, median over repeats after a
warm-up, as samples/s; "s/epoch" is 80 such steps (the standard dataset's 8,000
training potentials) plus a batched validation pass over 2,000.
Inference: one ``torch.no_grad`` forward at batch 1 and at batch 4,000 (100 times
each), as trajectories/s. Inputs are random: throughput does not depend on values.
"""

import argparse
import statistics
import time

import numpy as np
import torch

import nh_operators as nh
from nh_operators.models import cast_network

from nh_operators._backend import ensure_pytorch_backend  # noqa: E402
dde = ensure_pytorch_backend()


def _sync(device):
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def _median_time(fn, repeats, device):
    fn()  # warm-up
    _sync(device)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        _sync(device)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def measure(name, preset, device, repeats, rng):
    torch.manual_seed(0)
    net = cast_network(nh.build_model(name, preset), torch.float32).to(device)
    V = rng.uniform(-2, 2, (4000, 100)).astype(np.float32)
    y = rng.uniform(-1, 1, (4000, 100, 2)).astype(np.float32)
    t = np.linspace(0, 2, 100, dtype=np.float32)[:, None]
    data = nh.OperatorData((V[:100], t), y[:100], (V[:100], t), y[:100], beta=0.05)
    model = dde.Model(data, net)
    opt = torch.optim.AdamW(net.parameters(), lr=1e-4, betas=(0.85, 0.98))
    model.compile(opt, loss="mse", verbose=0)
    with torch.device(device):
        step = _median_time(lambda: model.train_step((V[:100], t), y[:100], None),
                            repeats, device)
    net.eval()
    tt = torch.as_tensor(t, device=device)
    one = torch.as_tensor(V[:1], device=device)
    many = torch.as_tensor(V, device=device)
    with torch.no_grad():
        b1 = _median_time(lambda: net((one, tt)), max(repeats, 10), device)
        b4000 = _median_time(lambda: net((many, tt)), max(1, repeats // 2), device)
    epoch = 80 * step + 0.5 * b4000  # 2,000 validation potentials
    return {"params": nh.count_parameters(net), "step": step, "train": 100 / step,
            "epoch": epoch, "b1": 1 / b1, "b1_ms": 1e3 * b1, "b4000": 4000 / b4000}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default=",".join(nh.MODELS))
    parser.add_argument("--presets", default="cpu,paper")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    device = torch.device(args.device)
    rng = np.random.default_rng(0)
    where = (torch.cuda.get_device_name(device) if device.type == "cuda"
             else f"CPU, {torch.get_num_threads()} threads")
    print(f"device: {where}; torch {torch.__version__}; medians of {args.repeats}")
    print(f"{'model':<10}{'preset':<7}{'params':>11}{'train samples/s':>17}"
          f"{'s/epoch':>9}{'infer b=1 ms':>14}{'traj/s b=1':>12}{'traj/s b=4000':>15}")
    for preset in args.presets.split(","):
        for name in args.models.split(","):
            r = measure(name, preset, device, args.repeats, rng)
            print(f"{name:<10}{preset:<7}{r['params']:>11,}{r['train']:>17,.0f}"
                  f"{r['epoch']:>9.1f}{r['b1_ms']:>14.2f}{r['b1']:>12,.0f}"
                  f"{r['b4000']:>15,.0f}", flush=True)


if __name__ == "__main__":
    main()
