"""What the public API adds over a network's raw forward (issue 41, Deliver §4).

In one process, per thread setting (torch and numba both set to it), µs per trajectory
at batch 1 and at ``--rows`` (1,000 by default), medians of ``--repeats`` rounds after a
warm-up round. In each round every path runs once, in turn (round robin, each round
starting one path later), so a burst of load from other jobs on a shared machine hits all
paths alike:

* ``raw``: the network's forward under ``torch.no_grad()`` on a float tensor of the
  sensor values, its output cast to float64 NumPy (what any call must do at least);
* ``public``: ``nh.pretrained(name)(V, TIMES)`` (times checked, domain check, then
  :func:`~nh_operators.predict`);
* ``predict``: ``nh.predict(nh.pretrained(name), V, TIMES)`` (no domain check);
* ``RK4 ×1``: ``nh.integrate_sensors(V, TIMES, substeps=1, check_resolution=False)``,
  the classical baseline at its cheapest.

``public/raw`` and ``predict/raw`` are the ratios of the medians (goal at batch 1,000:
≤ 1.10). Inputs: ``BoundedPotentialSpace(seed=1)`` potentials at the 100 sensors,
float64 (N, 100), from rest, at the 100 times of :data:`~nh_operators.TIMES`.

Run it with::

    OMP_WAIT_POLICY=PASSIVE python benchmarks/cost/api_overhead.py [--threads 1 2] \
        [--rows 1000] [--repeats 41]

``OMP_WAIT_POLICY=PASSIVE`` keeps idle OpenMP threads from spinning on a shared CPU
(see ``benchmarks/cost/user_paths.py``). ``--threads 2`` needs numba started with at
least 2 threads (``NUMBA_NUM_THREADS`` unset or ≥ 2).
"""

import argparse
import os
import statistics
import time
from collections.abc import Callable

import numba
import numpy as np
import torch

import nh_operators as nh
from nh_operators.potentials import in_domain

NETWORKS = ("phaseonet-alg1", "phaseonet-alg1-quadrature", "deeponet-alg1")
PATHS = ("raw", "public", "predict", "RK4 ×1")


def raw_forward(method: nh.NeuralMethod) -> Callable[[np.ndarray], tuple]:
    """The bare forward of ``method.net``: float tensor in, float64 (q, p) out.

    Args:
        method: a shipped network (:func:`nh_operators.pretrained`).

    Returns:
        callable ``V (N, 100) -> (q, p)``, each (N, 100) float64 views.
    """
    net = method.net.eval()
    dtype = next(net.parameters()).dtype
    times = torch.tensor(nh.TIMES[:, None], dtype=dtype)

    def run(V: np.ndarray) -> tuple:
        with torch.no_grad():
            y = net((torch.as_tensor(V, dtype=dtype), times)).double().numpy()
        return y[..., 0], y[..., 1]

    return run


def paths(method: nh.NeuralMethod) -> dict[str, Callable[[np.ndarray], object]]:
    """The four timed paths for one network, by name (see the module docstring).

    Args:
        method: a shipped network.

    Returns:
        dict path name -> callable of the sensor values.
    """
    return {"raw": raw_forward(method),
            "public": lambda V: method(V, nh.TIMES),
            "predict": lambda V: nh.predict(method, V, nh.TIMES),
            "RK4 ×1": lambda V: nh.integrate_sensors(V, nh.TIMES, substeps=1,
                                                      check_resolution=False)}


def round_robin(fns: dict[str, Callable[[], object]], repeats: int) -> dict[str, float]:
    """Median seconds of each callable, timed in turn ``repeats`` times after a warm-up.

    Round r starts at the r-th callable (in rotation), so none always runs first, after
    the others have filled the caches with their own data.

    Args:
        fns: name -> callable with no arguments.
        repeats: timed rounds (≥ 1).

    Returns:
        name -> median seconds of one call.
    """
    for fn in fns.values():
        fn()
    times: dict[str, list[float]] = {name: [] for name in fns}
    order = list(fns.items())
    for r in range(repeats):
        for name, fn in order[r % len(order):] + order[:r % len(order)]:
            start = time.perf_counter()
            fn()
            times[name].append(time.perf_counter() - start)
    return {name: statistics.median(ts) for name, ts in times.items()}


def table(V: np.ndarray, names: list[str], threads: int, repeats: int, numba_max: int) -> None:
    """Print one markdown table (µs per trajectory and ratios) at ``threads`` threads.

    Args:
        V: sensor values (N, 100); batch 1 is its first row.
        names: shipped networks.
        threads: torch's and numba's thread count for this table.
        repeats: rounds at batch N (batch 1 gets 5× as many).
        numba_max: numba's thread count at start-up (it cannot go above it).
    """
    torch.set_num_threads(threads)
    numba.set_num_threads(min(threads, numba_max))
    print(f"\n### {threads} thread(s) (torch {torch.get_num_threads()}, numba "
          f"{numba.get_num_threads()}); µs per trajectory, medians\n")
    print("| network | batch | raw | public | predict | RK4 ×1 | public/raw | predict/raw |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for name in names:
        fns = paths(nh.pretrained(name))
        for rows, reps in ((V[:1], 5 * repeats), (V, repeats)):
            med = round_robin({k: (lambda f=f, r=rows: f(r)) for k, f in fns.items()}, reps)
            us = {k: 1e6 * med[k] / len(rows) for k in PATHS}
            print(f"| {name} | {len(rows)} | " + " | ".join(
                f"{us[k]:.1f}" if len(rows) == 1 else f"{us[k]:.2f}" for k in PATHS)
                + f" | {us['public'] / us['raw']:.3f} | {us['predict'] / us['raw']:.3f} |",
                flush=True)


def main() -> None:
    """Parse the options, build the inputs and print a table per thread setting."""
    numba_max = numba.get_num_threads()  # NUMBA_NUM_THREADS, or the cores
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--rows", type=int, default=1000, help="potentials per batch")
    parser.add_argument("--repeats", type=int, default=41,
                        help="timed rounds at batch --rows (≥ 20; batch 1: 5×)")
    parser.add_argument("--threads", type=int, nargs="+", default=[1])
    parser.add_argument("--networks", nargs="*", default=list(NETWORKS))
    args = parser.parse_args()
    space = nh.BoundedPotentialSpace(seed=1)
    V = space.potentials(space.random(args.rows)).V(nh.SENSORS)
    inside = int(np.count_nonzero(in_domain(V)))
    load = os.getloadavg()
    print(f"{args.rows} Algorithm-1 potentials (BoundedPotentialSpace(seed=1); {inside} in "
          f"the generator's domain), float64 sensor values, from rest, at nh.TIMES; "
          f"{args.repeats} rounds; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; "
          f"OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY', 'unset')}")
    for threads in args.threads:
        table(V, args.networks, threads, args.repeats, numba_max)
    load = os.getloadavg()
    print(f"\nload average at the end: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")


if __name__ == "__main__":
    main()
