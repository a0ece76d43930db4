"""Wall time to generate labelled datasets of random bounded potentials in memory.

Measures :func:`nh_operators.data.generate_dataset` (drawing, exact labels by the
compiled reference solve, filtering of invalid samples) for each size in ``--sizes``
with seed 8407 (the standard dataset), and reports the median of ``--repeats`` runs
after one warm-up run of 200 samples (numba compiles on the first call). The table gives
throughput, dropped samples and the time extrapolated to 1,000,000 samples.

Run it with::

    python benchmarks/cost/label_generation.py [--sizes 1000,10000] [--repeats 3]

Goal (DESIGN §5): ≤ 30 s for 10,000 samples on 2 cores.
"""

import argparse
import os
import platform
import statistics
import time

import numba

from nh_operators.data import DATASET_PRESETS as PRESETS, generate_dataset
from nh_operators.evaluation import cpu_name

SEED = PRESETS["standard"]["seed"]
WARMUP_SIZE = 200
EXTRAPOLATE_TO = 1_000_000


def machine_description():
    """Processor, OS and core counts of this machine, on one line."""
    uname = platform.uname()
    cpu = cpu_name()
    return (f"{cpu} ({uname.machine}), {uname.system} {uname.release}; "
            f"CPU count {os.cpu_count()}, numba threads {numba.get_num_threads()}")


def time_generation(n, seed, repeats):
    """Median wall time of ``repeats`` in-memory generations of n samples, and drops.

    Returns:
        (median seconds, number of dropped draws in the last run).
    """
    times = []
    drops = 0
    for _ in range(repeats):
        start = time.perf_counter()
        ds = generate_dataset(n, seed, progress=False)
        times.append(time.perf_counter() - start)
        drops = int(ds.attrs["n_dropped"])
    return statistics.median(times), drops


def format_table(rows, repeats):
    """Markdown table of (n, seconds, drops) rows."""
    lines = [
        f"Label generation in memory, seed {SEED}, median of {repeats} runs "
        "(goal: ≤ 30 s for 10,000 on 2 cores)",
        "",
        "| n | median s | samples/s | drops | extrapolated s for 1,000,000 |",
        "|---:|---:|---:|---:|---:|",
    ]
    for n, seconds, drops in rows:
        lines.append(f"| {n:,} | {seconds:.2f} | {n / seconds:,.0f} | {drops} | "
                     f"{seconds / n * EXTRAPOLATE_TO:,.0f} |")
    return "\n".join(lines)


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", default="1000,10000",
                        help="comma-separated dataset sizes (default: 1000,10000)")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs per size (default: 3)")
    parser.add_argument("--seed", type=int, default=SEED, help=f"generator seed (default: {SEED})")
    args = parser.parse_args(argv)
    args.sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
    if not args.sizes or min(args.sizes) < 1 or args.repeats < 1:
        parser.error("sizes and repeats must be positive")
    return args


def main(argv=None):
    args = parse_args(argv)
    print(machine_description())
    start = time.perf_counter()
    generate_dataset(WARMUP_SIZE, args.seed, progress=False)
    print(f"warm-up ({WARMUP_SIZE} samples, includes numba compilation or cache load): "
          f"{time.perf_counter() - start:.2f} s\n")
    rows = [(n, *time_generation(n, args.seed, args.repeats)) for n in args.sizes]
    print(format_table(rows, args.repeats))


if __name__ == "__main__":
    main()
