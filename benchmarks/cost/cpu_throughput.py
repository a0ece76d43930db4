"""CPU training throughput against thread count and ``torch.compile`` (issue 13, §3).

    python benchmarks/cost/cpu_throughput.py [--models traonet,fno] [--threads 1 2]
                                        [--batch 50] [--repeats 20] [--modes eager]

Two trainings side by side, one thread each (how this project trains on 2 cores), are
measured by starting two copies at once with ``--threads 1 --modes eager``.

For each network, built as its shipped ``MODEL-paper`` folder's config says (the tuned
recipe's options, the `cpu` preset; weights as shipped), one training step is forward, MSE
on the 100-time grid, backward and an AdamW update at batch ``--batch``, on random
inputs (throughput does not depend on values). Rows: eager PyTorch, and the same
network wrapped in ``torch.compile`` (default mode; its first steps, the compilation,
are timed apart). Reported: median samples/s over ``--repeats`` steps after 3 warm-up
steps, and the ratio to eager at the same thread count. Run it on a quiet machine: a
second process on the cores changes every number.
"""

import argparse
import statistics
import time

import numpy as np
import torch

import nh_operators as nh
from nh_operators.solving.catalog import WEIGHTS
from nh_operators.training import load_model

from nh_operators._backend import ensure_pytorch_backend  # noqa: E402
ensure_pytorch_backend()


def step_time(net, V, t, y, repeats):
    """(seconds of the first 3 steps, median seconds per step after them)."""
    opt = torch.optim.AdamW(net.parameters(), lr=1e-4)

    def step():
        opt.zero_grad(set_to_none=True)
        loss = torch.mean((net((V, t)) - y) ** 2)
        loss.backward()
        opt.step()

    start = time.perf_counter()
    for _ in range(3):
        step()
    first = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        step()
        times.append(time.perf_counter() - start)
    return first, statistics.median(times)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", default="traonet,fno")
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--batch", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--modes", nargs="+", default=["eager", "compiled"],
                        choices=["eager", "compiled"])
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    V = torch.as_tensor(rng.uniform(-2, 2, (args.batch, 100)), dtype=torch.float32)
    y = torch.as_tensor(rng.uniform(-1, 1, (args.batch, 100, 2)), dtype=torch.float32)
    t = torch.linspace(0, 2, 100)[:, None]
    print(f"torch {torch.__version__}; batch {args.batch}; medians of {args.repeats} "
          "steps after 3 warm-up steps")
    print(f"{'model':<10}{'threads':>8}  {'mode':<9}{'samples/s':>11}{'vs eager':>10}"
          f"{'first 3 steps, s':>18}")
    for name in args.models.split(","):
        for threads in args.threads:
            torch.set_num_threads(threads)
            eager = None
            for mode in args.modes:
                net = load_model(WEIGHTS / f"{name}-paper")[0]
                net.train()
                if mode == "compiled":
                    torch._dynamo.reset()
                    net = torch.compile(net)
                try:
                    first, step = step_time(net, V, t, y, args.repeats)
                except Exception as err:  # report a compiler that fails, go on
                    print(f"{name:<10}{threads:>8}  {mode:<9}  failed: "
                          f"{type(err).__name__}: {str(err).splitlines()[0][:80]}")
                    continue
                rate = args.batch / step
                if mode == "eager":
                    eager = rate
                ratio = f"{rate / eager:>10.2f}" if eager else f"{'–':>10}"
                print(f"{name:<10}{threads:>8}  {mode:<9}{rate:>11,.0f}{ratio}"
                      f"{first:>18.1f}", flush=True)


if __name__ == "__main__":
    main()
