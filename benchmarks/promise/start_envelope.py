"""The classical promise on sensor values with coarse starts per row (issue 41): every
answer of ``solve_many(method="classical")`` within tol, and what it costs.

Groups as in ``sensor_contract.py`` (2,000 out-of-distribution potentials, and fresh draws
of Algorithm 1 and the paper's generator, as their 100 sensor values, released at rest at
q = 0, each row at its own 1–100 random times in [0, 2]). Truth: RK4 at 4,096 substeps on
the spline. Per group and tol: the share of rows inside the envelope of
:mod:`nh_operators.solvers.start_envelope` (those that start coarse), the share whose
orbit passes the spline's guard (the kink rule), the worst true L_tot / tol, the rows
over tol (the contract asks none) and µs per row. ``--start resolved`` switches the coarse
starts off (``START_TOLS = ()``); ``--start K`` lets every row in (K levels coarser, the
envelope ignored), to show what the envelope keeps out.

``--cost`` times the envelope's march (:func:`row_flags`) on ``--n`` generator rows, as
sensor values and as B-spline curves, at 1 and 2 numba threads.

``--replay`` instead replays RK4's levels (8 to 2,048 substeps; truth 16,384) on the rows
whose orbit passes the guard and scores the kink rule's depth: accept the first level
whose last ``d`` gaps, times ``KINK_SAFETY``, meet tol (how ``DEEP_GAPS`` was chosen).

Run it with::

    python benchmarks/promise/start_envelope.py [--n 2000] [--seed 9001]
        [--tols 1e-2 1e-3 1e-4 1e-5 1e-6 1e-7 1e-8] [--start default|resolved|K]
    python benchmarks/promise/start_envelope.py --replay [--seed 9001]
    python benchmarks/promise/start_envelope.py --cost [--n 2000]
"""

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import nh_operators as nh
import nh_operators.solvers.start_level as start_level
from nh_operators.solvers.level_grid import KINK_SAFETY
from nh_operators.solvers.rows import row_source
from nh_operators.solvers.start_envelope import INSIDE, PAST_GUARD, row_flags

sys.path.insert(0, str(Path(__file__).parent))
from sensor_contract import asked_times, groups  # noqa: E402

TRUTH = 4096
REPLAY_TRUTH, REPLAY_LEVELS = 16384, 8 * 2 ** np.arange(9)


def truth(V: np.ndarray, t: np.ndarray, substeps: int) -> tuple[np.ndarray, np.ndarray]:
    q, p = np.empty(t.shape), np.empty(t.shape)
    for i in range(len(V)):  # each row at its own times
        qi, pi = nh.integrate_sensors(V[i:i + 1], t[i], substeps=substeps,
                                      check_resolution=False)
        q[i], p[i] = qi[0], pi[0]
    return q, p


def l_tot(q, p, q_ref, p_ref) -> np.ndarray:
    return 0.5 * (((q - q_ref) ** 2).mean(-1) + ((p - p_ref) ** 2).mean(-1))


def set_start(start: str) -> None:
    """``default`` (the package's rule), ``resolved`` (no coarse start), or K levels
    coarser for every row, inside the envelope or not."""
    if start == "resolved":
        start_level.START_TOLS = ()
    elif start != "default":
        levels = int(start)
        start_level.START_TOLS = (0.0,) * levels
        start_level.row_flags = lambda src, q0s, p0s: (row_flags(src, q0s, p0s)
                                                       & PAST_GUARD) | INSIDE


def contract(args) -> None:
    set_start(args.start)
    rng = np.random.default_rng(args.seed)
    print(f"seed {args.seed}, {args.n} rows per group, start {args.start}, truth RK4 "
          f"×{TRUTH} on the spline")
    print("| inputs | tol | rows | inside | past guard | over tol | worst true / tol "
          "| µs per row |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for label, V in groups(args.n, args.seed).items():
        t = asked_times(len(V), rng)
        q_ref, p_ref = truth(V, t, TRUTH)
        zero = np.zeros(len(V))
        flags = row_flags(row_source(V, "sensors"), zero, zero)
        for tol in args.tols:
            t0 = time.perf_counter()
            sol = nh.solve_many(V, t, tol=tol, method="classical")
            us = 1e6 * (time.perf_counter() - t0) / len(V)
            ratio = l_tot(sol.q, sol.p, q_ref, p_ref) / tol
            print(f"| {label} | {tol:g} | {len(V)} | {np.mean(flags & INSIDE > 0):.1%} | "
                  f"{np.mean(flags & PAST_GUARD > 0):.1%} | {int((ratio > 1).sum())} | "
                  f"{ratio.max():.2g} | {us:.0f} |", flush=True)


def replay(args) -> None:
    rng = np.random.default_rng(args.seed)
    V = groups(args.n, args.seed)["out of distribution"]
    t = asked_times(len(V), rng)
    zero = np.zeros(len(V))
    rows = np.flatnonzero(row_flags(row_source(V, "sensors"), zero, zero) & PAST_GUARD)
    errs = np.empty((rows.size, REPLAY_LEVELS.size))
    gaps = np.full_like(errs, np.inf)
    for k, r in enumerate(rows):
        q_ref, p_ref = truth(V[r:r + 1], t[r:r + 1], REPLAY_TRUTH)
        before = None
        for j, s in enumerate(REPLAY_LEVELS):
            q, p = nh.integrate_sensors(V[r:r + 1], t[r], substeps=int(s),
                                        check_resolution=False)
            errs[k, j] = l_tot(q[0], p[0], q_ref[0], p_ref[0])
            if before is not None:
                gaps[k, j] = l_tot(q[0], p[0], *before)
            before = (q[0], p[0])
    print(f"seed {args.seed}: {rows.size} of {len(V)} out-of-distribution rows pass the "
          f"guard; levels {REPLAY_LEVELS[0]}–{REPLAY_LEVELS[-1]} substeps, truth RK4 "
          f"×{REPLAY_TRUTH}; a row no level satisfies counts at the finest")
    print("| gaps counted | tol | over tol | worst true / tol | median accepted substeps |")
    print("|---:|---:|---:|---:|---:|")
    for depth in (2, 3, 4):
        for tol in args.tols:
            worst, over, accepted = 0.0, 0, []
            for k in range(rows.size):
                j = next((j for j in range(depth, REPLAY_LEVELS.size)
                          if gaps[k, j - depth + 1:j + 1].max() * KINK_SAFETY <= tol),
                         REPLAY_LEVELS.size - 1)
                worst, over = max(worst, errs[k, j] / tol), over + (errs[k, j] > tol)
                accepted.append(REPLAY_LEVELS[j])
            print(f"| {depth} | {tol:g} | {over} | {worst:.2g} | {np.median(accepted):.0f} |",
                  flush=True)


def cost(args) -> None:
    import numba

    space = nh.BoundedPotentialSpace(seed=args.seed)
    pots = space.potentials(space.random(args.n))
    zero = np.zeros(args.n)
    sources = {"sensors": row_source(pots.V(nh.SENSORS), "sensors"),
               "B-spline curves": row_source(pots, "exact V")}
    print(f"{args.n} Algorithm-1 potentials (seed {args.seed}) from rest; median of 31 calls")
    print("| rows | numba threads | µs per row |")
    print("|---|---:|---:|")
    for threads in (1, 2):
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
        for name, src in sources.items():
            row_flags(src, zero, zero)
            seconds = []
            for _ in range(31):
                t0 = time.perf_counter()
                row_flags(src, zero, zero)
                seconds.append(time.perf_counter() - t0)
            print(f"| {name} | {numba.get_num_threads()} | "
                  f"{1e6 * float(np.median(seconds)) / args.n:.2f} |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000, help="rows per group")
    ap.add_argument("--seed", type=int, default=9001)
    ap.add_argument("--tols", type=float, nargs="+",
                    default=[1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8])
    ap.add_argument("--start", default="default", help="default, resolved, or 0-3")
    ap.add_argument("--replay", action="store_true", help="score the kink rule's depth")
    ap.add_argument("--cost", action="store_true", help="time the envelope's march")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    (cost if args.cost else replay if args.replay else contract)(args)


if __name__ == "__main__":
    main()
