"""Our networks next to DeepXDE's DeepONetCartesianProd on four operator problems.

The problems (``operator_problems.py``): a data-driven antiderivative, and
physics-informed Poisson (1-D), advection in (x, t) and Stokes flow in a lid-driven
cavity in (x, y) with outputs (u, v, p). Every network is trained with Adam (lr 1e-3,
DeepXDE's loop) and scored by the mean relative l2 error on test functions against
independent references, twice from one run: at ``--iterations`` iterations (equal
iterations) and after ``--seconds`` seconds of training (equal wall clock; evaluation
time excluded). A run stops when both are reached, or at 2 × ``--seconds`` (then the
equal-iterations entry says how far it got). Physics-informed runs use
``query_coupled=False``; our networks are the ``cpu`` presets with the problem's m, k,
d, query range and scales. One CPU thread.

Run from the repository root::

    OMP_NUM_THREADS=1 python benchmarks/problems/deepxde_problems.py --out table.md
    python benchmarks/problems/deepxde_problems.py --quick   # seconds, a smoke test
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))

import nh_operators as nh  # noqa: E402
from nh_operators._backend import ensure_pytorch_backend  # noqa: E402
from nh_operators.models import KLData  # noqa: E402
from operator_problems import PROBLEMS, Problem, build_problem  # noqa: E402

dde = ensure_pytorch_backend()

NETWORKS = ["deepxde", "deeponet", "traonet", "varonet", "mambonet", "fno"]
#: Default (iterations, seconds) per problem: ~25 CPU minutes for the whole table.
BUDGETS = {"antiderivative": (1000, 15), "poisson": (300, 20), "advection": (200, 20),
           "stokes": (50, 25)}
#: VaRONet's KL weight (the paper's β).
BETA = 5.4963e-2


def build_network(name: str, problem: Problem, seed: int = 0) -> torch.nn.Module:
    """Network ``name`` (``NETWORKS``) sized for ``problem``; weights from ``seed``.

    Raises:
        ValueError: for an unknown name.
    """
    torch.manual_seed(seed)
    m, k, d = problem.n_sensors, problem.n_outputs, problem.query_dim
    lo, hi = problem.query_range
    if name == "deepxde":
        width = 128 if k == 1 else 40 * k  # k outputs: split_both, 40 basis functions each
        net = dde.nn.DeepONetCartesianProd([m, 128, 128, width], [d, 128, 128, width],
                                           "tanh", "Glorot normal", num_outputs=k,
                                           multi_output_strategy=None if k == 1
                                           else "split_both")
    elif name not in NETWORKS:
        raise ValueError(f"unknown network {name!r}; choose from {NETWORKS}")
    else:
        extra = {}
        if name in ("traonet", "mambonet"):
            extra = dict(time_scale=(problem.grid_points - 1) / (hi - lo),
                         activation="gelu")
        elif name in ("varonet", "fno"):
            extra = dict(query_range=(lo, hi))
            if name == "fno":
                extra.update(n_grid=problem.grid_points if d == 1 else 32,
                             n_modes=16 if d == 1 else 8)
        net = nh.build_model(name, "cpu", n_sensors=m, n_outputs=k, query_dim=d,
                             query_coupled=False, **extra)
    if problem.output_transform is not None:
        net.apply_output_transform(problem.output_transform)
    return net


def predict(model: dde.Model, problem: Problem) -> np.ndarray:
    """The model's predictions on the problem's test functions and points."""
    net = model.net
    was = net.training
    net.eval()
    with torch.no_grad():
        v = torch.as_tensor(problem.test_v, dtype=dde.config.real(torch))
        x = torch.as_tensor(problem.test_x, dtype=dde.config.real(torch))
        out = torch.cat([net((v[i:i + 50], x)) for i in range(0, len(v), 50)])
    net.train(was)
    return out.double().numpy()


class Budget(dde.callbacks.Callback):
    """Scores the model at an iteration count and after a training time, then stops.

    Args:
        problem: the problem (its test data give the score).
        iterations: the equal-iterations checkpoint.
        seconds: the equal-wall-clock checkpoint (training time only).
        cap: stop at this training time even before ``iterations``.
    """

    def __init__(self, problem: Problem, iterations: int, seconds: float, cap: float):
        super().__init__()
        self.problem, self.iterations, self.seconds, self.cap = (problem, iterations,
                                                                 seconds, cap)
        self.at_iterations = self.at_seconds = None
        self.t0 = self.spent_eval = None

    def on_epoch_begin(self) -> None:
        if self.t0 is None:
            self.t0, self.spent_eval = time.perf_counter(), 0.0

    def _score(self, step: int, elapsed: float) -> tuple:
        start = time.perf_counter()
        score = self.problem.metric(predict(self.model, self.problem))
        self.spent_eval += time.perf_counter() - start
        return step, elapsed, score

    def on_batch_end(self) -> None:
        step = self.model.train_state.step
        elapsed = time.perf_counter() - self.t0 - self.spent_eval
        if self.at_iterations is None and step >= self.iterations:
            self.at_iterations = self._score(step, elapsed)
        if self.at_seconds is None and elapsed >= self.seconds:
            self.at_seconds = self._score(step, elapsed)
        if self.at_seconds and self.at_iterations is None and elapsed >= self.cap:
            self.at_iterations = (step, elapsed, float("nan"))  # cut: how far it got
        if self.at_iterations and self.at_seconds:
            self.model.stop_training = True


def run(problem: Problem, name: str, iterations: int, seconds: float, seed: int) -> dict:
    """Train one network on one problem; the two scores and the run's facts."""
    net = build_network(name, problem, seed)
    data = KLData(problem.data, BETA) if name == "varonet" else problem.data
    model = dde.Model(data, net)
    budget = Budget(problem, iterations, seconds, cap=2 * seconds)
    with contextlib.redirect_stdout(io.StringIO()):
        model.compile("adam", lr=1e-3)
        model.train(iterations=10 ** 7, batch_size=problem.batch_size,
                    display_every=10 ** 7, callbacks=[budget], verbose=0)
    params = sum(p.numel() for p in net.parameters())
    loss = float(np.sum(model.train_state.loss_train))
    return dict(problem=problem.name, network=name, params=params, seed=seed,
                iterations=budget.at_iterations, seconds=budget.at_seconds,
                final_loss=loss)


def table(rows: list, header: str) -> str:
    """The Markdown table of ``rows`` (one per problem, network and seed)."""
    lines = [header, "",
             "| problem | network | parameters | equal iterations: its | s | rel. l2 "
             "| equal wall clock: s | its | rel. l2 |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        (i_it, i_s, i_e), (s_it, s_s, s_e) = r["iterations"], r["seconds"]
        i_e = "not reached" if np.isnan(i_e) else f"{i_e:.3g}"
        lines.append(f"| {r['problem']} | {r['network']} | {r['params']:,} | {i_it} | "
                     f"{i_s:.1f} | {i_e} | {s_s:.1f} | {s_it} | {s_e:.3g} |")
    return "\n".join(lines)


def main(argv=None) -> str:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--problems", nargs="+", default=list(PROBLEMS), choices=PROBLEMS)
    parser.add_argument("--networks", nargs="+", default=NETWORKS, choices=NETWORKS)
    parser.add_argument("--iterations", type=int, help="equal-iterations checkpoint "
                        "(default per problem: " + ", ".join(
                            f"{p} {b[0]}" for p, b in BUDGETS.items()) + ")")
    parser.add_argument("--seconds", type=float, help="equal-wall-clock checkpoint "
                        "(default per problem: " + ", ".join(
                            f"{p} {b[1]}" for p, b in BUDGETS.items()) + ")")
    parser.add_argument("--seeds", type=int, default=1, help="seeds per cell (default 1)")
    parser.add_argument("--quick", action="store_true",
                        help="20 iterations / 2 s per run, small data: a smoke test")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--out", type=Path, help="also write the table here")
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    started = time.perf_counter()
    rows, sizes = [], {}
    for pname in args.problems:
        kw = {}
        if args.quick:
            kw = dict(n_train=32, n_test=10, batch_size=8)
        problem = build_problem(pname, **kw)
        sizes[pname] = problem.sizes
        its, secs = BUDGETS[pname]
        if args.quick:
            its, secs = 20, 2.0
        its = args.iterations or its
        secs = args.seconds or secs
        for name in args.networks:
            for seed in range(args.seeds):
                rows.append(run(problem, name, its, secs, seed))
                print(f"{pname} {name} seed {seed}: {rows[-1]['seconds'][2]:.3g}",
                      file=sys.stderr)
    minutes = (time.perf_counter() - started) / 60
    load = "/".join(f"{x:.1f}" for x in os.getloadavg())
    size_text = "; ".join(f"{p}: " + ", ".join(f"{k} {v}" for k, v in s.items())
                          for p, s in sizes.items())
    header = (f"Mean relative l2 error on the test functions. Device: CPU "
              f"({platform.processor() or platform.machine()}), {args.threads} thread(s) "
              f"(load average of the shared machine at the end: {load}), "
              f"float32, Adam lr 1e-3, {args.seeds} seed(s); {minutes:.1f} minutes in "
              f"all. Sizes: {size_text}. Command: python "
              f"benchmarks/problems/deepxde_problems.py "
              + " ".join(argv if argv is not None else sys.argv[1:]))
    text = table(rows, header)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return text


if __name__ == "__main__":
    main()
