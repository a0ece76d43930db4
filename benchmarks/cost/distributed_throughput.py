"""Data-parallel training throughput and memory per rank, for 1 and 2 processes.

    python benchmarks/cost/distributed_throughput.py --data FILE.h5 [--procs 1 2]
        [--preset cpu] [--epochs 2] [--memory-only] [--max-rows R]

For each process count N this starts ``torchrun --nproc_per_node N`` on this script
(``--worker``), every process on one thread (``OMP_NUM_THREADS=1``), gloo on the CPU.
Each rank

1. opens the file with :class:`~nh_operators.data.H5Rows` and builds its
   :class:`~nh_operators.data.ShardedOperatorData` (global batch 100), reads its rows of
   the first epoch, and reports the bytes of rows it holds (its training rows of an
   epoch and its share of the validation set), its resident memory before and after,
   and the read time;
2. unless ``--memory-only``: trains the model with :func:`nh_operators.train` from the
   file for ``--epochs`` epochs (float32, the paper's batch of 100), and reports the
   wall time of the last epoch, from which samples/s = training rows / that time
   (the epoch's training steps, its sharded validation pass and its row read).

The table lists, per N: samples/s, speed-up over N = 1, and per rank the rows' memory,
the growth of resident memory when the data was loaded, and the peak resident memory.
"""

import argparse
import json
import os
import resource
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _rss_mb():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def _peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def worker(args):
    import numpy as np

    import nh_operators as nh
    from nh_operators.data import H5Rows, ShardedOperatorData
    from nh_operators.training import init_distributed

    dist = init_distributed("cpu")
    before = _rss_mb()
    start = time.perf_counter()
    rows = H5Rows(args.data, verify=False)
    data = ShardedOperatorData(rows, batch_size=args.batch_size, rank=dist.rank,
                               world_size=dist.world_size, dtype=np.float32,
                               max_rows=args.max_rows)
    data.train_next_batch(args.batch_size)  # reads the rank's rows of epoch 0
    result = {"rank": dist.rank, "world_size": dist.world_size,
              "rows_mb": data.memory_bytes() / 2**20, "rss_before_mb": before,
              "rss_data_mb": _rss_mb(), "read_s": time.perf_counter() - start,
              "n_train": data.n_train}
    del data
    if not args.memory_only:
        seconds = []
        cfg = nh.TrainConfig("traonet", preset=args.preset, epochs=args.epochs, seed=0,
                             batch_size=args.batch_size, device="cpu")
        nh.train(cfg, args.data, Path(args.out) / "run", progress=False,
                 max_rows=args.max_rows,
                 epoch_callback=lambda record, net: seconds.append(record["seconds"]))
        last = seconds[-1] - (seconds[-2] if len(seconds) > 1 else 0.0)
        result.update(epoch_s=last, samples_per_s=result["n_train"] / last)
    result["peak_rss_mb"] = _peak_mb()
    Path(args.out, f"rank{dist.rank}.json").write_text(json.dumps(result))
    dist.close()


def _port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def launch(args, nproc):
    with tempfile.TemporaryDirectory() as out:
        command = [sys.executable, "-m", "torch.distributed.run", "--nproc_per_node",
                   str(nproc), "--master-addr", "127.0.0.1", "--master-port", str(_port()),
                   __file__, "--worker", "--data", args.data, "--out", out,
                   "--preset", args.preset, "--epochs", str(args.epochs),
                   "--batch-size", str(args.batch_size)]
        if args.memory_only:
            command.append("--memory-only")
        if args.max_rows:
            command += ["--max-rows", str(args.max_rows)]
        env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
        subprocess.run(command, env=env, check=True)
        return [json.loads(Path(out, f"rank{r}.json").read_text()) for r in range(nproc)]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True, help="dataset .h5")
    parser.add_argument("--procs", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--preset", default="cpu", choices=["cpu", "paper"])
    parser.add_argument("--epochs", type=int, default=2)
    parser.add_argument("--batch-size", type=int, default=100)
    parser.add_argument("--memory-only", action="store_true")
    parser.add_argument("--max-rows", type=int, help="training rows a rank holds at once")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--out", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        return worker(args)
    results = {n: launch(args, n) for n in args.procs}
    first = results[args.procs[0]][0]
    print(f"\n{args.data}: {first['n_train']} training rows, global batch "
          f"{args.batch_size}, TraONet ({args.preset}), 1 thread per process, gloo\n")
    head = (f"{'procs':>5} {'samples/s':>10} {'speed-up':>8} {'rank':>4} {'rows MB':>8} "
            f"{'RSS +data MB':>12} {'peak RSS MB':>11} {'read s':>7}")
    print(head)
    print("-" * len(head))
    base = results[args.procs[0]][0].get("samples_per_s")
    for n, ranks in results.items():
        rate = ranks[0].get("samples_per_s")
        for r in ranks:
            lead = (f"{n:>5} {rate:>10.1f} {rate / base:>8.2f}" if rate and r["rank"] == 0
                    else f"{n:>5} {'-':>10} {'-':>8}" if r["rank"] == 0 else " " * 25)
            print(f"{lead} {r['rank']:>4} {r['rows_mb']:>8.1f} "
                  f"{r['rss_data_mb'] - r['rss_before_mb']:>12.1f} "
                  f"{r['peak_rss_mb']:>11.1f} {r['read_s']:>7.1f}")


if __name__ == "__main__":
    main()
