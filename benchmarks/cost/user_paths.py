"""The user-facing paths, timed as a user calls them, beside the raw kernels (issue 41).

In one process, for each thread setting (torch and numba both set to 1, then to the
default 2; ``--threads``), medians of ``--repeats`` runs, µs per trajectory:

1. **Classical, to a tolerance**, at tol 1e-3, 1e-6 and 1e-9, on three kinds of input:
   sensor values (N, 100), the generator's B-spline curves themselves (a batched
   :class:`~nh_operators.BoundedPotential`), and typed formulas (a fixed family of
   ``--formulas`` strings, warm: each already parsed and compiled, as from its second
   solve on). Columns: ``nh.solve`` in a loop (on at most ``--loop-cap`` rows),
   ``nh.solve_many`` on all rows (``method="classical"``: the classical promise; the
   networks have their own table), the worst true L_tot of solve_many's answers over tol
   (must be ≤ 1), and the **oracle**: the cheapest fixed-step method and substep count
   that meets tol on *every* row of that batch, found in hindsight against an accurate
   reference (RK4 at ``REF_SUBSTEPS`` substeps, checked against half of it), timed on
   the same rows through the same compiled kernel solve uses for that kind. ``price`` is
   solve_many / oracle: what the promise costs over the answer.
2. **Networks**: ``nh.pretrained(name)(V, TIMES)`` and ``nh.predict`` at batch 1 and
   ``--rows`` (1,000 by default), beside the network's raw forward under ``no_grad``
   and ``nh.integrate_sensors`` (RK4 at 1 and 4 substeps, no resolution check), with the
   median L_tot of each against the exact B-spline trajectory.

All potentials are Algorithm-1 generator potentials (seed 42), started at rest at q = 0
(the state the networks answer), queried at the 100 times of :data:`~nh_operators.TIMES`.

Run it with (under 10 minutes on a busy 2-core shared CPU; ``--quick``: about two)::

    OMP_WAIT_POLICY=PASSIVE python benchmarks/cost/user_paths.py [--rows 1000] \
        [--threads 1 2] [--quick]

``OMP_WAIT_POLICY=PASSIVE`` matters on a shared machine only: by default OpenMP's idle
threads (torch's and numba's) spin, and with other processes on both cores a 2-thread
PhaseONet forward at batch 1 took 11–15 ms instead of 0.3 ms, RK4 ×1 at batch 1,000
57 µs per row instead of 8; with it the 2-thread rows are the 1-thread rows or better.
"""

import argparse
import contextlib
import statistics
import warnings

import numba
import numpy as np
import torch

import nh_operators as nh
from nh_operators._backend import single_threaded
from nh_operators.evaluation import time_call
from nh_operators.potentials import BoundedPotentialSpace
from nh_operators.solvers import METHODS
from nh_operators.solvers import rows as rows_mod
from nh_operators.solvers.classical_solve import coerce_potential

TOLS = (1e-3, 1e-6, 1e-9)
REF_SUBSTEPS = 256
SPACING = float(nh.TIMES[1] - nh.TIMES[0])
NETWORKS = ("phaseonet-alg1", "phaseonet-alg1-quadrature", "deeponet-alg1")


def median_time(fn, repeats: int) -> float:
    """Median wall time of ``repeats`` calls of ``fn`` (seconds, no warm-up call)."""
    return statistics.median(time_call(fn, repeats=repeats, warmup=0))


def formulas(n: int, seed: int = 3) -> list[str]:
    """``n`` bounded formulas: V(0) = V(1) = 2 and V < 2 inside."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        a = rng.uniform(3.0, 8.0)
        b = rng.uniform(-a, 3.0 * a)
        c = rng.uniform(-0.5, 0.5)
        out.append(f"2 - {a:.4f}*q*(1-q) + {b:.4f}*q**2*(1-q)**2 "
                   f"+ {c:.4f}*q*(1-q)*sin(6*q)")
    return out


def l_tot(q, p, ref):
    """Per-row L_tot of (q, p) against ref = (q_ref, p_ref)."""
    return 0.5 * (np.mean((q - ref[0]) ** 2, -1) + np.mean((p - ref[1]) ** 2, -1))


class Kind:
    """One kind of input: its rows as solve takes them, and the fixed-step kernel."""

    def __init__(self, name: str, rows: list, batch):
        self.name, self.rows, self.batch = name, rows, batch

    def sources(self):
        """RowSources as solve builds them (one for a batch, one per formula)."""
        if self.name == "formula":
            return [rows_mod.row_source(*coerce_potential(f)) for f in self.rows]
        information = "sensors" if self.name == "sensors" else "exact V"
        return [rows_mod.row_source(self.batch, information)]

    def fixed(self, method: str, substeps: int):
        """(q, p) (N, 100) of every row at a fixed method and substep count."""
        qs, ps = [], []
        interval = np.array([SPACING])
        for src in self.sources():
            n = src.params.shape[0]
            z = np.zeros(n)
            # one row (a formula) on one thread, as solve runs it: a parallel launch for
            # a single row costs more than its arithmetic (75-85 µs against 10-15)
            with single_threaded() if n == 1 else contextlib.nullcontext():
                q, p = rows_mod._level(src, np.arange(n), nh.TIMES[None], interval, z, z,
                                       substeps, method, shared=True)
            qs.append(q)
            ps.append(p)
        return np.concatenate(qs), np.concatenate(ps)


def oracle(kind: Kind, ref, tol: float, repeats: int, errors: dict):
    """The cheapest (method, substeps) meeting tol on every row; (name, seconds)."""
    best = None
    for method in METHODS:
        for k in range(0, 9):
            sub = 2 ** k
            if (method, sub) not in errors:
                errors[method, sub] = float(l_tot(*kind.fixed(method, sub), ref).max())
            if errors[method, sub] <= tol:
                seconds = median_time(lambda m=method, s=sub: kind.fixed(m, s), repeats)
                if best is None or seconds < best[1]:
                    best = (f"{method}×{sub}", seconds)
                break
    return best or ("none ≤ 256", float("nan"))


def classical_table(kinds, threads, args, errors):
    print(f"\n### Classical to a tolerance, {threads} thread(s); µs per trajectory\n")
    print("| input | tol | loop solve | solve_many | loop/many | worst true/tol "
          "| oracle | oracle µs | price (many/oracle) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for kind in kinds:
        n = len(kind.rows)
        ref = kind.ref
        for tol in TOLS:
            k = min(n, args.loop_cap)
            t_loop = median_time(lambda: [nh.solve(kind.rows[i], nh.TIMES, tol=tol,
                                                   method="classical") for i in range(k)],
                                 1 if args.quick else 2) / k
            out = {}

            def many():
                out["s"] = nh.solve_many(kind.batch, nh.TIMES, tol=tol, method="classical",
                                         progress=False)

            t_many = median_time(many, args.repeats) / n
            worst = float(l_tot(out["s"].q, out["s"].p, ref).max()) / tol
            name, t_or = oracle(kind, ref, tol, args.repeats, errors.setdefault(kind.name, {}))
            t_or /= n
            print(f"| {kind.name} | {tol:g} | {1e6 * t_loop:.1f} | {1e6 * t_many:.1f} | "
                  f"{t_loop / t_many:.1f} | {worst:.2g} | {name} | {1e6 * t_or:.2f} | "
                  f"{t_many / t_or:.1f} |", flush=True)


def network_table(V, truth, threads, args):
    n = V.shape[0]
    print(f"\n### Networks and kernels, {threads} thread(s); µs per trajectory\n")
    print("| what | batch 1 | batch %d | median L_tot (batch %d) |" % (n, n))
    print("|---|---|---|---|")
    reps = max(args.repeats, 5)

    def row(label, fn):
        t1 = median_time(lambda: fn(V[:1]), 3 * reps)
        res = {}
        tn = median_time(lambda: res.setdefault("out", fn(V)), reps) / n
        err = float(np.median(l_tot(*res["out"], truth)))
        print(f"| {label} | {1e6 * t1:.1f} | {1e6 * tn:.2f} | {err:.2g} |", flush=True)

    for sub in (1, 4):
        row(f"integrate_sensors RK4 ×{sub}",
            lambda v, s=sub: nh.integrate_sensors(v, nh.TIMES, substeps=s,
                                                   check_resolution=False))
    tt = torch.tensor(nh.TIMES[:, None], dtype=torch.float32)
    for name in args.networks:
        method = nh.pretrained(name)
        net = method.net.eval()
        dtype = next(net.parameters()).dtype

        def raw(v, net=net, dtype=dtype):
            with torch.no_grad():
                y = net((torch.as_tensor(v, dtype=dtype), tt.to(dtype))).double().numpy()
            return y[..., 0], y[..., 1]

        row(f"{name}: raw forward (no_grad)", raw)
        row(f"{name}: pretrained(name)(V, t)", lambda v, m=method: m(v, nh.TIMES))
        row(f"{name}: nh.predict", lambda v, m=method: nh.predict(m, v, nh.TIMES))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rows", type=int, default=1000, help="potentials per batch")
    parser.add_argument("--formulas", type=int, default=20)
    parser.add_argument("--loop-cap", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--networks", nargs="*", default=list(NETWORKS),
                        help="shipped networks to time (default: %(default)s); the flag "
                        "alone times none, only the kernels beside them")
    parser.add_argument("--kinds", nargs="+", default=["sensors", "bspline", "formula"],
                        choices=["sensors", "bspline", "formula"],
                        help="the input kinds of the classical table")
    parser.add_argument("--quick", action="store_true",
                        help="200 rows, 8 formulas, loop on 30 rows")
    args = parser.parse_args()
    if args.quick:
        args.rows, args.formulas, args.loop_cap = min(args.rows, 200), 8, 30
    warnings.simplefilter("ignore")  # out-of-domain and resolution warnings: timed alike
    space = BoundedPotentialSpace(seed=42)
    pots = space.potentials(space.random(args.rows))
    V = pots.V(nh.SENSORS)
    sensors = Kind("sensors", list(V), V)
    bspline = Kind("bspline", [pots[i] for i in range(args.rows)], pots)
    texts = formulas(args.formulas)
    formula = Kind("formula", texts, texts)
    kinds = [k for k in (sensors, bspline, formula) if k.name in args.kinds]
    gaps = []
    for kind in kinds:  # references, and every kernel compiled before any timing
        kind.ref = kind.fixed("rk4", REF_SUBSTEPS)
        half = kind.fixed("rk4", REF_SUBSTEPS // 2)
        gaps.append(f"{kind.name} {l_tot(*half, kind.ref).max():.1g}")
        for tol in TOLS:
            nh.solve_many(kind.batch[:2], nh.TIMES, tol=tol, method="classical")
            nh.solve(kind.rows[0], nh.TIMES, tol=tol, method="classical")
    for f in texts if formula in kinds else ():  # parsed and compiled (from a 2nd solve)
        nh.solve(f, nh.TIMES, tol=1e-3, method="classical")
        nh.solve(f, nh.TIMES, tol=1e-3, method="classical")
    truth = bspline.ref if bspline in kinds else bspline.fixed("rk4", REF_SUBSTEPS)
    print(f"{args.rows} Algorithm-1 potentials (seed 42; {args.formulas} formulas), from "
          f"rest, 100 times on [0, 2]; repeats {args.repeats}; reference RK4 ×{REF_SUBSTEPS} "
          f"(max L_tot to ×{REF_SUBSTEPS // 2}: {', '.join(gaps)})")
    errors = {}
    default = (torch.get_num_threads(), numba.get_num_threads())
    for threads in args.threads:
        torch.set_num_threads(threads)
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        network_table(V, truth, threads, args)
        classical_table(kinds, threads, args, errors)
    torch.set_num_threads(default[0])
    numba.set_num_threads(default[1])


if __name__ == "__main__":
    main()
