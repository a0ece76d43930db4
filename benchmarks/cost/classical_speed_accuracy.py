"""Speed and accuracy of the classical solvers on the 4,000-potential test set (seed 42).

Every method predicts q, p at the dataset's query times and is scored against the
dataset's exact labels with the paper's per-sample loss L_tot (mean and median over the
samples). Rows:

- sensor information (V at the 100 sensors, the force from a spline of them, as a neural
  operator sees it): RK4 at 1-16 steps per output interval, the symplectic Verlet and
  Yoshida 4/6/8 methods, RK4 on a PCHIP interpolant, the paper's RK4 row (rebuilt
  correctly), and scipy's adaptive DOP853 on the same not-a-knot cubic spline at several
  tolerances (one trajectory at a time, on a subset of ``--dop853-size`` potentials);
- exact V (the true B-spline potential): RK4 at 1 and 4 steps per interval.

The batched methods run on all N potentials at once (compiled, parallel over the batch).
Each method is timed after a warm-up call on two potentials, as the median of
``--repeats`` runs (DOP853: ``--dop853-repeats``); the table gives µs per trajectory.
Then the goal checks: RK4 on sensors at 4 substeps reaches mean L_tot ≤ 1e-10, and its
speed against the cheapest DOP853 tolerance at least as accurate.

Run it with::

    python benchmarks/cost/classical_speed_accuracy.py [--test FILE.h5] [--size N]
"""

import argparse
import os
import platform
import statistics
import time
from dataclasses import dataclass

import numba
import numpy as np

from nh_operators.data import DATASET_PRESETS as PRESETS, generate_dataset, load_dataset
from nh_operators.evaluation import dop853_sensors, loss_per_sample
from nh_operators.solvers import integrate, integrate_sensors, paper_rk4

GOAL_RK4_LOSS = 1e-10
GOAL_RK4_SUBSTEPS = 4
DOP853_TOLERANCES = (1e-6, 1e-8, 1e-10, 1e-12)
SENSORS_INFO, EXACT_INFO = "sensors", "exact V"
#: Fixed-step methods on the sensors: (method, substeps).
SENSOR_RUNS = [("rk4", k) for k in (1, 2, 4, 8, 16)] + [
    ("verlet", 4), ("verlet", 16), ("yoshida4", 4), ("yoshida6", 2), ("yoshida8", 1),
    ("yoshida8", 2),
]
EXACT_RK4_SUBSTEPS = (1, 4)


@dataclass(frozen=True)
class Method:
    """A solver row: ``run(V, potentials, t) -> (q, p)`` on a batch of samples."""

    name: str
    information: str
    run: callable
    batched: bool = True


@dataclass(frozen=True)
class Row:
    name: str
    information: str
    n: int
    us_per_trajectory: float
    mean_loss: float
    median_loss: float


def build_methods():
    """All benchmarked methods, in table order."""
    methods = [
        Method(f"{m} ({k} substep{'s' * (k > 1)})", SENSORS_INFO,
               lambda V, pots, t, m=m, k=k: integrate_sensors(V, t, m, k))
        for m, k in SENSOR_RUNS
    ]
    methods += [
        Method("rk4 pchip (4 substeps)", SENSORS_INFO,
               lambda V, pots, t: integrate_sensors(V, t, "rk4", 4, interpolation="pchip")),
        Method("paper_rk4 (pchip, 1 substep)", SENSORS_INFO, lambda V, pots, t: paper_rk4(V, t)),
    ]
    methods += [
        Method(f"DOP853 rtol=atol={tol:g}", SENSORS_INFO,
               lambda V, pots, t, tol=tol: dop853_sensors(V, t, tol), batched=False)
        for tol in DOP853_TOLERANCES
    ]
    methods += [
        Method(f"rk4 ({k} substep{'s' * (k > 1)})", EXACT_INFO,
               lambda V, pots, t, k=k: integrate(pots, t, "rk4", k))
        for k in EXACT_RK4_SUBSTEPS
    ]
    return methods


def measure(method, V, pots, t, q_ref, p_ref, repeats):
    """Warm up on two samples, time ``repeats`` runs on all of V, score the last run."""
    method.run(V[:2], pots[:2], t)
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        q, p = method.run(V, pots, t)
        times.append(time.perf_counter() - start)
    loss = loss_per_sample(q, p, q_ref, p_ref)["L_tot"]
    n = V.shape[0]
    return Row(method.name, method.information, n, statistics.median(times) / n * 1e6,
               float(np.mean(loss)), float(np.median(loss)))


def format_table(rows):
    lines = [
        "| method | information | N | µs per trajectory | mean L_tot | median L_tot |",
        "|---|---|---:|---:|---:|---:|",
    ]
    lines += [f"| {r.name} | {r.information} | {r.n} | {r.us_per_trajectory:,.1f} | "
              f"{r.mean_loss:.3e} | {r.median_loss:.3e} |" for r in rows]
    return "\n".join(lines)


def goal_checks(rows, rk4_subset_mean):
    """Lines checking (a) the RK4 accuracy goal and (b) its speed against DOP853.

    (b) compares on the same potentials: a DOP853 row qualifies when its mean L_tot is at
    most RK4's mean on the DOP853 subset (``rk4_subset_mean``).
    """
    rk4 = next(r for r in rows if r.information == SENSORS_INFO
               and r.name == f"rk4 ({GOAL_RK4_SUBSTEPS} substeps)")
    ok = rk4.mean_loss <= GOAL_RK4_LOSS
    lines = [f"(a) rk4 on sensors, {GOAL_RK4_SUBSTEPS} substeps: mean L_tot = "
             f"{rk4.mean_loss:.3e} vs goal ≤ {GOAL_RK4_LOSS:g}: {'MET' if ok else 'NOT MET'}"]
    dop = [r for r in rows if r.name.startswith("DOP853")]
    enough = [r for r in dop if r.mean_loss <= rk4_subset_mean]
    head = (f"(b) rk4 ({GOAL_RK4_SUBSTEPS} substeps) mean L_tot on the {dop[0].n} DOP853 "
            f"potentials: {rk4_subset_mean:.3e}; ")
    if enough:
        best = min(enough, key=lambda r: r.us_per_trajectory)
        ratio = best.us_per_trajectory / rk4.us_per_trajectory
        lines.append(
            head + f"cheapest DOP853 at least as accurate: {best.name} (mean "
            f"{best.mean_loss:.3e}, {best.us_per_trajectory:,.1f} µs per trajectory): rk4 "
            f"({rk4.us_per_trajectory:,.1f} µs) is {ratio:,.0f}× faster")
    else:
        lines.append(head + "no DOP853 tolerance reached it (best mean "
                     f"{min(r.mean_loss for r in dop):.3e})")
    return lines


def machine_description():
    uname = platform.uname()
    return (f"{platform.processor() or uname.machine}, {uname.system} {uname.release}; "
            f"CPU count {os.cpu_count()}, numba threads {numba.get_num_threads()}")


def load_test_set(path, size):
    """The test set from an HDF5 file, else generated in memory (first ``size`` samples)."""
    preset = PRESETS["test"]
    if path:
        ds = load_dataset(path)
        return ds, f"{path} (seed {ds.seed}, {len(ds)} samples)"
    size = preset["size"] if size is None else size
    start = time.perf_counter()
    ds = generate_dataset(size, preset["seed"], progress=False)
    return ds, (f"generated in memory: {size} samples, seed {preset['seed']} "
                f"({time.perf_counter() - start:.1f} s)")


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--test", help="test set HDF5 file (default: generate it in memory)")
    parser.add_argument("--size", type=int, help="use only the first SIZE samples (default: all)")
    parser.add_argument("--dop853-size", type=int, default=200,
                        help="potentials solved one by one with DOP853 (default: 200)")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs per method (default: 5)")
    parser.add_argument("--dop853-repeats", type=int, default=1,
                        help="timed runs per DOP853 tolerance (default: 1)")
    args = parser.parse_args(argv)
    if min(args.dop853_size, args.repeats, args.dop853_repeats, args.size or 1) < 1:
        parser.error("sizes and repeats must be positive")
    return args


def main(argv=None):
    args = parse_args(argv)
    ds, source = load_test_set(args.test, args.size)
    n = len(ds) if args.size is None else min(args.size, len(ds))
    V, q_ref, p_ref, t = ds.V[:n], ds.q[:n], ds.p[:n], ds.t
    pots = ds.potentials()[:n]
    m = min(args.dop853_size, n)
    print(f"test set: {source}; {n} potentials, {t.size} query times")
    print(f"machine: {machine_description()}\n")
    rows = []
    for method in build_methods():
        if method.batched:
            rows.append(measure(method, V, pots, t, q_ref, p_ref, args.repeats))
        else:
            rows.append(measure(method, V[:m], pots[:m], t, q_ref[:m], p_ref[:m],
                                args.dop853_repeats))
    print(format_table(rows))
    print()
    q4, p4 = integrate_sensors(V[:m], t, "rk4", GOAL_RK4_SUBSTEPS)
    subset_mean = float(np.mean(loss_per_sample(q4, p4, q_ref[:m], p_ref[:m])["L_tot"]))
    print("\n".join(goal_checks(rows, subset_mean)))


if __name__ == "__main__":
    main()
