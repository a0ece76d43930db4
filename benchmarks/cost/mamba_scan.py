"""Training-step cost of the pure-PyTorch Mamba block: custom scan vs a plain loop.

One training step (forward, mean-square loss, backward) of a stack of pre-norm residual
Mamba blocks, ``x + Mamba(LayerNorm(x))``, at batch 100 and length 100, with
:func:`~nh_operators.models._scan.selective_scan` (custom autograd function) and with
:func:`~nh_operators.models._scan.selective_scan_reference` (autograd loop over time).
Each configuration runs in its own subprocess, so that the peak-RSS growth
(``resource.getrusage``) belongs to it alone; the time is the median of ``--repeats``
steps after one warm-up step.

Run it with::

    python benchmarks/cost/mamba_scan.py [--repeats 3] [--threads N] [--reference-128]

Timings on a shared machine are only meaningful when it is otherwise idle: with all
cores busy, the many small parallel kernels of a scan stall on each other (10x or more).
"""

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time

import torch
from torch import nn

from nh_operators.models import _scan
from nh_operators.models import mamba as mamba_module

SCANS = {"custom": _scan.selective_scan, "reference": _scan.selective_scan_reference}


class Stack(nn.Module):
    """Pre-norm residual Mamba blocks."""

    def __init__(self, d_model, n_layers):
        super().__init__()
        self.norms = nn.ModuleList(nn.LayerNorm(d_model) for _ in range(n_layers))
        self.blocks = nn.ModuleList(mamba_module.Mamba(d_model, layer_idx=i)
                                    for i in range(n_layers))

    def forward(self, x):
        for norm, block in zip(self.norms, self.blocks):
            x = x + block(norm(x))
        return x


def peak_rss_mib():
    # ru_maxrss is in KiB on Linux
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def measure(scan, d_model, batch, length, n_layers, repeats, seed=0):
    """Median seconds of one training step, and the peak-RSS growth in MiB."""
    mamba_module.selective_scan = SCANS[scan]  # the block looks the scan up at call time
    torch.manual_seed(seed)
    model = Stack(d_model, n_layers)
    x = torch.randn(batch, length, d_model, generator=torch.Generator().manual_seed(seed))

    def step():
        model.zero_grad(set_to_none=True)
        loss = model(x).square().mean()
        loss.backward()

    rss0 = peak_rss_mib()
    step()  # warm-up
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        step()
        times.append(time.perf_counter() - t0)
    return {"seconds": statistics.median(times), "rss_mib": peak_rss_mib() - rss0}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, default=100)
    parser.add_argument("--length", type=int, default=100)
    parser.add_argument("--layers", type=int, default=4)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, default=None,
                        help="torch threads (default: torch's choice); 1 is steadier on a "
                             "busy machine, where parallel kernels wait for each other")
    parser.add_argument("--reference-128", action="store_true",
                        help="also time the reference loop at d_model 128 (slow)")
    parser.add_argument("--one", nargs=2, metavar=("SCAN", "D_MODEL"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    shape = (args.batch, args.length, args.layers, args.repeats)
    if args.threads:
        torch.set_num_threads(args.threads)

    if args.one:  # child process: one configuration, JSON on stdout
        result = measure(args.one[0], int(args.one[1]), *shape)
        print(json.dumps(result))
        return

    configs = [("custom", 128), ("custom", 32), ("reference", 32)]
    if args.reference_128:
        configs.append(("reference", 128))
    print(f"torch {torch.__version__}, threads {torch.get_num_threads()}; batch {args.batch}, "
          f"length {args.length}, {args.layers} blocks (d_state 16, expand 2); "
          f"median of {args.repeats} after warm-up")
    print(f"{'scan':<10} {'d_model':>7} {'s/step':>8} {'peak RSS +MiB':>14}")
    for scan, d_model in configs:
        cmd = [sys.executable, __file__, "--one", scan, str(d_model),
               "--batch", str(args.batch), "--length", str(args.length),
               "--layers", str(args.layers), "--repeats", str(args.repeats),
               "--threads", str(torch.get_num_threads())]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
        r = json.loads(out.strip().splitlines()[-1])
        print(f"{scan:<10} {d_model:>7} {r['seconds']:>8.3f} {r['rss_mib']:>14.0f}", flush=True)


if __name__ == "__main__":
    main()
