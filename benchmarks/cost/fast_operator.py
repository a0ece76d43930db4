"""Ablation of PhaseONet, the fast operator: one change per row, cost and accuracy.

    python benchmarks/cost/fast_operator.py train --dataset paper --data-dir DIR --out DIR
                                             [--rows base,width128] [--epochs 30]
    python benchmarks/cost/fast_operator.py report --dataset paper --data-dir DIR --out DIR
    python benchmarks/cost/fast_operator.py solve --dataset paper [--size 10000] [--seed 4242]
                                             [--also RUN_DIR] [--head-to-head-only]
                                             [--no-head-to-head] [--tols 1e-3,1e-6,1e-9]

``train`` trains the asked rows (all by default) through ``nh.train`` (DeepXDE's loop)
into ``OUT/<dataset>-<row>/``, one thread per process: run two processes with
disjoint ``--rows`` to use both cores. A finished row is skipped and a cut one resumes.
``report`` then, in one process and one thread, scores every trained row on the
validation split (rows 80 % … 100 % of the dataset, never the test set) and times it
at batch 1 and batch 1,000 on 1,000 validation potentials (float32, ``torch.no_grad``,
median of ``--repeats``), next to RK4 on the sensors at 1 substep timed in the same run,
and prints a markdown table. Inference-only rows (bfloat16, TorchScript,
``torch.compile``, two threads) reuse the base row's weights.

``solve`` measures what the shipped networks save ``nh.solve_many`` on ``--size`` fresh
potentials of the dataset's distribution given as sensor values, at the 100 standard
times and tol 1e-3, 1e-4, 1e-5 (``--tols``): ``method="auto"`` (a network where its calibrated
estimate meets tol) against ``method="rk4"`` (the classical solver alone), the median of
``--solve-repeats`` calls of each, alternating, after :func:`nh_operators.preload` and a
warm-up on 50 rows, one thread. Every answer is checked against
the truth of what ``solve_many`` was given, the sensor spline's trajectory (RK4 at 256
substeps of the grid, as the calibration's sensor family), not the B-spline's labels.

Data (``--data-dir``): ``paper-extended.h5`` / ``alg1-extended.h5`` (100,000
potentials, seed 8407: ``nh-operators generate --preset paper-extended``) and
``paper-standard.h5`` / ``alg1-standard.h5`` (10,000) for the data-volume row.
Every row trains ``--epochs`` epochs of the 100k set's 80,000 training potentials at
batch 256 (the 10k row: the same number of steps), lr 2e-3, ExpHyperbolicLR, seed 0.
"""

import argparse
import contextlib
import json
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import torch

import nh_operators as nh
from nh_operators.evaluation import time_call
from nh_operators.evaluation.methods import classical_methods
from nh_operators.training import read_history

sys.path.insert(0, str(Path(__file__).resolve().parent))
import time_head  # noqa: E402  (the head-time row's network, next to this script)

BASE = dict(width=256, depth=2, basis=32, grid=256)
#: row → (architecture changes, data size "100k" or "10k").
ROWS = {
    "base": ({}, "100k"),
    "head-time": ({}, "100k"),   # time_head.TimeHeadONet: the grid in time, not phase
    "width128": ({"width": 128}, "100k"),
    "width192": ({"width": 192}, "100k"),
    "width512": ({"width": 512}, "100k"),
    "depth1": ({"depth": 1}, "100k"),
    "depth3": ({"depth": 3}, "100k"),
    "basis16": ({"basis": 16}, "100k"),
    "basis64": ({"basis": 64}, "100k"),
    "grid64": ({"grid": 64}, "100k"),
    "relu": ({"activation": "relu"}, "100k"),
    "data10k": ({}, "10k"),
    # the shape computed by inverting the period's quadrature, the MLP a correction
    "quadrature": ({"shape": "quadrature"}, "100k"),
    "quadrature-nodes128": ({"shape": "quadrature", "nodes": 128}, "100k"),
    "quadrature-small": ({"shape": "quadrature", "width": 32, "depth": 1, "basis": 8},
                         "100k"),
    "quadrature-nodes128-grid128": ({"shape": "quadrature", "nodes": 128, "grid": 128},
                                    "100k"),
    "quadrature-tiny": ({"shape": "quadrature", "grid": 128, "width": 16, "depth": 1,
                         "basis": 4}, "100k"),
    "quadrature-tiny-nodes128": ({"shape": "quadrature", "nodes": 128, "grid": 128,
                                  "width": 16, "depth": 1, "basis": 4}, "100k"),
}
INFERENCE_ROWS = ("bfloat16", "torchscript", "compile", "threads2")
FILES = {"100k": "{}-extended.h5", "10k": "{}-standard.h5"}
#: Rows whose network is not PhaseONet: built under the name "phaseonet" inside these.
NETWORKS = {"head-time": time_head.registered}


def _built_as(row):
    """The context in which ``row``'s network is built and loaded."""
    return NETWORKS.get(row, contextlib.nullcontext)()


def _data_path(args, size):
    return os.path.join(args.data_dir, FILES[size].format(args.dataset))


def train_rows(args):
    torch.set_num_threads(1)
    for row in args.rows:
        arch, size = ROWS[row]
        epochs = args.epochs * (10 if size == "10k" else 1)
        cfg = nh.TrainConfig(model="phaseonet", preset="paper", arch={**BASE, **arch},
                             epochs=epochs, batch_size=256, lr=2e-3,
                             upper_bound=max(300, epochs), seed=args.seed)
        out = os.path.join(args.out, f"{args.dataset}-{row}")
        if os.path.exists(os.path.join(out, "done.json")):
            print(f"{row}: done")
            continue
        start = time.perf_counter()
        with _built_as(row):
            nh.train(cfg, _data_path(args, size), out, resume=True, progress=False)
        record = {"row": row, "minutes": (time.perf_counter() - start) / 60,
                  "epochs": epochs, "threads": 1}
        tmp = os.path.join(out, "done.json.tmp")
        with open(tmp, "w") as f:
            json.dump(record, f)
        os.replace(tmp, os.path.join(out, "done.json"))
        print(f"{row}: {record['minutes']:.1f} min", flush=True)


def _validation(args):
    import h5py

    with h5py.File(_data_path(args, "100k")) as f:
        n = len(f["V"])
        rows = slice(int(0.8 * n), n)
        return f["V"][rows], f["q"][rows], f["p"][rows]


def _time(fn, repeats):
    """Median seconds of ``repeats`` calls after one warm-up."""
    return statistics.median(time_call(fn, repeats=repeats, warmup=1))


def _speed(forward, V, repeats):
    """µs per trajectory at batch 1 (median over 20 potentials) and at batch 1,000."""
    t = torch.as_tensor(nh.TIMES, dtype=torch.float32)[:, None]
    one = [_time(lambda v=V[i:i + 1]: forward(v, t), repeats) for i in range(20)]
    many = _time(lambda: forward(V, t), repeats)
    return statistics.median(one) * 1e6, many / len(V) * 1e6


def _score(net, V, q, p):
    t = nh.TIMES[:, None]
    y = np.concatenate([out.double().numpy()
                        for _, out in nh.models.batched_forward(net, V, t, 1000)])
    loss = 0.5 * (((y[..., 0] - q) ** 2).mean(1) + ((y[..., 1] - p) ** 2).mean(1))
    return float(loss.mean()), float(np.median(loss))


def report(args):
    torch.set_num_threads(1)
    V, q, p = _validation(args)
    V32 = torch.as_tensor(V[:1000], dtype=torch.float32)
    table = []
    rk4 = classical_methods(["rk4_sensors_1"])["rk4_sensors_1"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        qh, ph = rk4(V, nh.TIMES)
    loss = 0.5 * (((qh - q) ** 2).mean(1) + ((ph - p) ** 2).mean(1))
    times = [_time(lambda v=V[i:i + 1]: rk4(v, nh.TIMES), args.repeats) for i in range(20)]
    table.append(("RK4 on sensors, 1 substep", "-", float(loss.mean()),
                  float(np.median(loss)), statistics.median(times) * 1e6,
                  _time(lambda: rk4(V[:1000], nh.TIMES), args.repeats) / 1000 * 1e6))
    base = None
    for row in ROWS:
        out = os.path.join(args.out, f"{args.dataset}-{row}")
        if not os.path.exists(os.path.join(out, "done.json")):
            continue
        with open(os.path.join(out, "done.json")) as f:
            done = json.load(f)
        with _built_as(row):
            net, _ = nh.load_model(out)
        base = net if row == "base" else base
        mean, median = _score(net, V, q, p)
        with torch.no_grad():
            one, many = _speed(lambda v, t: net((v, t)), V32, args.repeats)
        minutes = read_history(out)["seconds"][-1] / 60  # resumed parts included
        table.append((row, f"{minutes:.1f} min, {done['epochs']} ep", mean, median,
                      one, many))
    if base is not None:
        table.extend(_inference_rows(base, V, q, p, V32, args.repeats))
    print(f"dataset {args.dataset}: validation {len(V)} potentials; CPU, float32, "
          f"threads 1 unless said; µs per trajectory, median of {args.repeats}")
    print("| row | training | val mean L_tot | val median | µs batch 1 | µs batch 1000 |")
    print("|---|---|---|---|---|---|")
    for name, trained, mean, median, one, many in table:
        print(f"| {name} | {trained} | {mean:.2e} | {median:.2e} | {one:.1f} | {many:.2f} |")


def _inference_rows(net, V, q, p, V32, repeats):
    rows = []
    for row in INFERENCE_ROWS:
        try:
            forward, score = _variant(row, net)
        except Exception as err:  # report what fails, e.g. compile without a compiler
            print(f"{row}: {type(err).__name__}: {err}")
            continue
        mean, median = score(V, q, p)
        with torch.no_grad():
            one, many = _speed(forward, V32, repeats)
        torch.set_num_threads(1)
        rows.append((row, "base weights", mean, median, one, many))
    return rows


class _Pair(torch.nn.Module):
    """(V, t) as two arguments, for ``torch.jit.trace``."""

    def __init__(self, net):
        super().__init__()
        self.net = net

    def forward(self, v, t):
        return self.net((v, t))


def _variant(row, net):
    t_grid = torch.as_tensor(nh.TIMES, dtype=torch.float32)[:, None]

    def score_with(forward):
        def score(V, q, p):
            with torch.no_grad():
                y = torch.cat([forward(torch.as_tensor(V[i:i + 1000], dtype=torch.float32),
                                       t_grid).float() for i in range(0, len(V), 1000)])
            y = y.double().numpy()
            loss = 0.5 * (((y[..., 0] - q) ** 2).mean(1) + ((y[..., 1] - p) ** 2).mean(1))
            return float(loss.mean()), float(np.median(loss))
        return score

    if row == "bfloat16":
        import copy
        low = copy.deepcopy(net)
        low.branch.to(torch.bfloat16)

        def forward(v, t):
            with torch.autocast("cpu", dtype=torch.bfloat16):
                return low((v, t))
    elif row == "torchscript":
        example = torch.as_tensor(2 - 8 * nh.SENSORS * (1 - nh.SENSORS), dtype=torch.float32)
        with torch.no_grad():
            forward = torch.jit.trace(_Pair(net).eval(), (example[None], t_grid),
                                      check_trace=False)
    elif row == "compile":
        compiled = torch.compile(lambda v, t: net((v, t)), dynamic=True)
        forward = compiled
    else:  # threads2
        def forward(v, t):
            torch.set_num_threads(2)
            return net((v, t))
    return forward, score_with(forward)


def _head_to_head(name, V, q, p, repeats, also=()):
    """The goal's comparison: the shipped network (float32) against RK4 on the sensors
    at 1 and 2 substeps (numba), and at 16, the sensor spline's information floor, on
    the same fresh potentials, timed in the same run; ``also``: run directories of other
    networks timed beside them."""
    net = nh.pretrained(name).net.eval()
    V32 = torch.as_tensor(V, dtype=torch.float32)
    methods = classical_methods(["rk4_sensors_1", "rk4_sensors_2", "rk4_sensors_16"])
    rows = []
    for label, method in methods.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            qh, ph = method(V, nh.TIMES)
            one = [_time(lambda v=V[i:i + 1]: method(v, nh.TIMES), repeats)
                   for i in range(20)]
            many = _time(lambda: method(V, nh.TIMES), repeats)
        loss = 0.5 * (((qh - q) ** 2).mean(1) + ((ph - p) ** 2).mean(1))
        rows.append((label, loss, statistics.median(one) * 1e6, many / len(V) * 1e6))
    mean, median = _score(net, V, q, p)
    with torch.no_grad():
        one, many = _speed(lambda v, t: net((v, t)), V32, repeats)
    print(f"head to head on {len(V)} fresh potentials (the first of the set below); "
          f"µs per trajectory, median of {repeats}, one thread")
    print("| method | mean L_tot | median | µs batch 1 | µs batch 1000 |")
    print("|---|---|---|---|---|")
    for label, loss, o, m in rows:
        print(f"| {label} | {loss.mean():.2e} | {np.median(loss):.2e} | {o:.0f} | {m:.2f} |")
    print(f"| {name} (float32) | {mean:.2e} | {median:.2e} | {one:.0f} | {many:.2f} |")
    for run in also:
        other = nh.load_model(run)[0].eval()
        mean, median = _score(other, V, q, p)
        with torch.no_grad():
            one, many = _speed(lambda v, t: other((v, t)), V32, repeats)
        print(f"| {run} (float32) | {mean:.2e} | {median:.2e} | {one:.0f} | {many:.2f} |")


def solve(args):
    from nh_operators.data import generate_dataset

    torch.set_num_threads(1)
    kwargs = {"normalization": "batch", "pool": int(args.size * 1.25)} \
        if args.dataset == "paper" else {}
    ds = generate_dataset(args.size, args.seed, progress=False, **kwargs)
    V, q, p = ds.V, ds.q, ds.p
    q_spline, p_spline = nh.integrate_sensors(V, nh.TIMES, substeps=256,
                                              check_resolution=False)
    name = f"phaseonet-{args.dataset}"
    if not args.no_head_to_head:
        _head_to_head(name, V[:1000], q[:1000], p[:1000], args.repeats, args.also)
    if args.head_to_head_only:
        return
    print(f"\n{args.size} fresh {args.dataset} potentials (seed {args.seed}) as sensor "
          f"values, {len(nh.TIMES)} times; CPU, one thread; shipped networks loaded first "
          f"(nh.preload); seconds: median of {args.solve_repeats} calls each, alternating")
    print("| tol | classical s | auto s | speed-up | network share (any network) | "
          "worst true/tol |")
    print("|---|---|---|---|---|---|")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        nh.preload()
        nh.solve_many(V[:50], nh.TIMES, tol=1e-3)
        nh.solve_many(V[:50], nh.TIMES, tol=1e-3, method="rk4")
        for tol in args.tols:
            seconds = {"rk4": [], "auto": []}
            for _ in range(args.solve_repeats):
                for method in seconds:
                    start = time.perf_counter()
                    sol = nh.solve_many(V, nh.TIMES, tol=tol, method=method)
                    seconds[method].append(time.perf_counter() - start)
                    if method == "auto":
                        auto = sol
                    del sol
            classical, neural = (float(np.median(seconds[m])) for m in ("rk4", "auto"))
            true = 0.5 * (((auto.q - q_spline) ** 2).mean(1)
                          + ((auto.p - p_spline) ** 2).mean(1))
            share = float(np.mean(auto.neural))  # any network: a row the other one
            # rejects goes on to this one, and the other may accept some rows
            print(f"| {tol:g} | {classical:.3f} | {neural:.3f} | {classical / neural:.2f}× | "
                  f"{share:.1%} | {true.max() / tol:.2g} |", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("command", choices=["train", "report", "solve"])
    ap.add_argument("--dataset", choices=["paper", "alg1"], default="paper")
    ap.add_argument("--data-dir")
    ap.add_argument("--out")
    ap.add_argument("--size", type=int, default=10000)
    ap.add_argument("--rows", default=",".join(ROWS))
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--seed", type=int, help="training seed (default 0) or, for solve, "
                    "the fresh potentials' seed (default 4242)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--solve-repeats", type=int, default=3,
                    help="solve: calls of each path per tolerance (the median is reported)")
    ap.add_argument("--also", action="append", default=[],
                    help="solve: a run directory timed beside the shipped network")
    ap.add_argument("--head-to-head-only", action="store_true",
                    help="solve: only the head-to-head table")
    ap.add_argument("--no-head-to-head", action="store_true",
                    help="solve: skip the head-to-head table (only solve_many's)")
    ap.add_argument("--tols", type=lambda s: [float(x) for x in s.split(",")],
                    default=[1e-3, 1e-4, 1e-5],
                    help="solve: the tolerances, comma-separated (default 1e-3,1e-4,1e-5)")
    args = ap.parse_args()
    args.rows = args.rows.split(",")
    unknown = sorted(set(args.rows) - set(ROWS))
    if unknown:
        ap.error(f"unknown rows {unknown}; choose from {list(ROWS)}")
    if args.command == "solve":
        args.seed = 4242 if args.seed is None else args.seed
        return solve(args)
    args.seed = 0 if args.seed is None else args.seed
    if not (args.data_dir and args.out):
        ap.error(f"{args.command} needs --data-dir and --out")
    train_rows(args) if args.command == "train" else report(args)


if __name__ == "__main__":
    main()
