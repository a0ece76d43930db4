"""The classical solve's tolerance contract, per call, on inputs no tuning saw.

``nh.solve_many(..., method="classical")`` answers every row to ``tol``; each row's true
L_tot is measured against an independent truth and compared with ``tol`` (the promise)
and with the row's ``error_estimate`` (its honesty). Families:

* ``alg1 B-spline``: Algorithm-1 potentials as exact B-spline curves, from (0, 0) (truth:
  the reference solve, adaptive Dormand–Prince in the curve parameter) and from random
  bounded states (truth: RK4 at 4096 substeps of the :data:`TIMES` spacing, h = 5e-6);
* ``alg1 sensors``: the same potentials' 100 sensor values (truth: RK4 on the sensor
  spline at 4096 substeps), from (0, 0) and from random states;
* ``ood formulas``: :func:`nh_operators.potentials.ood_potentials`, from (0, 0) (truth:
  DOP853 at 1e-13).

Each draw asks 1–20 uniform random times in [0, 2], shared by the rows of the draw.
The rule was chosen on seeds 777–779 (a replay of per-level solutions); the default
seeds here (2001+) were not used for it.

With ``--rules`` it instead replays every doubling level of the same inputs (solved to
tol 1e-300, each level's true error measured) and compares the estimate ``solve`` uses (the
larger of the last gap and the one before shrunk by RK4's rate: a bound on the coarser
level of the pair) with Richardson estimates of the finer level's error (that bound
divided by (ρ − 1)², ρ the observed ratio of the two gaps' square roots, capped at 16,
credited only where ρ ≥ 4; times a safety S): how close each is to the truth, how often
it is below it, and what it would accept.

With ``--start K`` every tol starts the doubling K levels coarser than
:data:`~nh_operators.solvers.start_level.RESOLVED_STEP` (K = 0…4; by default each tol starts where
:func:`~nh_operators.solvers.start_level.start_coarseness` says): how the thresholds
``COARSE_START_TOL``, ``COARSER_START_TOL`` and ``COARSEST_START_TOL`` are chosen, each on
a seed of its own (3001; 5001 for the third), then checked with all of them in place on a
fresh one (4001; 6001).

Run it with::

    python benchmarks/promise/classical_estimate.py [--size 100] [--draws 5] [--seed 2001]
        [--tols 1e-2 1e-4 1e-6 1e-8 1e-10] [--start K] [--out classical_estimate.json]
        [--rules]
"""

import argparse
import json
import time
import warnings

import numpy as np

import nh_operators as nh
from nh_operators.evaluation import device_info, loss_per_sample
from nh_operators.potentials import ood_potentials
from nh_operators.solvers import random_states
from nh_operators.solvers import rows as solver_rows
from nh_operators.solvers import start_level
from nh_operators.solvers.rows import row_source
from nh_operators.training import write_atomic

FINE = 4096  # substeps of the fixed-step truth


def force_start(levels: int) -> None:
    """Make every tol start ``levels`` levels coarser than ``RESOLVED_STEP`` (this
    process only; 4: a first step of two output intervals).

    Args:
        levels: 0 to 4.

    Raises:
        ValueError: ``levels`` out of that range.
    """
    if not 0 <= levels <= 4:
        raise ValueError(f"--start must be 0 to 4, got {levels}")
    start_level.START_TOLS = (0.0,) * levels


def families(size, seed):
    """name -> (potentials for solve_many, q0, p0, truth(t))."""
    rng = np.random.default_rng(seed)
    space = nh.BoundedPotentialSpace(seed=seed)
    pots = space.potentials(space.random(size))
    V = pots.V(nh.SENSORS)
    src = row_source(pots, "exact V")
    q0, p0 = random_states(src.values_at, size, rng)
    zero = np.zeros(size)
    ood = ood_potentials(max(size // 10, 5), seed)  # solved in Python, one by one

    def fixed(pot, sensors, a, b):
        integrate = nh.integrate_sensors if sensors else nh.integrate
        return lambda t: integrate(pot, t, substeps=FINE, q0=a, p0=b,
                                   check_resolution=False)

    def ood_truth(t):
        out = [nh.reference_solve(pot, t) for pot in ood]
        return np.stack([o[0] for o in out]), np.stack([o[1] for o in out])

    return {"alg1 B-spline, (0, 0)": (pots, zero, zero, lambda t: nh.reference_solve(pots, t)),
            "alg1 B-spline, states": (pots, q0, p0, fixed(pots, False, q0, p0)),
            "alg1 sensors, (0, 0)": (V, zero, zero, fixed(V, True, zero, zero)),
            "alg1 sensors, states": (V, q0, p0, fixed(V, True, q0, p0)),
            "ood formulas, (0, 0)": (ood, 0.0, 0.0, ood_truth)}


def measure(size, draws, seed, tols):
    rng = np.random.default_rng(seed + 1)
    rows = []
    for name, (pots, q0, p0, truth) in families(size, seed).items():
        records = {tol: [] for tol in tols}
        for _ in range(draws):
            t = rng.uniform(0.0, 2.0, int(rng.integers(1, 21)))
            q_ref, p_ref = truth(t)
            for tol in tols:
                start = time.perf_counter()
                sol = nh.solve_many(pots, t, q0=q0, p0=p0, tol=tol, method="classical")
                seconds = time.perf_counter() - start
                true = loss_per_sample(sol.q, sol.p, q_ref, p_ref)["L_tot"]
                records[tol].append((true, sol.error_estimate, sol.substeps,
                                     np.full(len(true), seconds / len(true))))
        for tol in tols:
            true, est, sub, sec = (np.concatenate(c) for c in zip(*records[tol], strict=True))
            moving = true > 0  # a particle at rest on a flat start is answered exactly
            ratio = est[moving] / true[moving]
            rows.append({"family": name, "tol": tol, "n": int(true.size),
                         "violations": int(np.sum(true > tol)),
                         "worst": float(true.max() / tol),
                         "under_estimated": int(np.sum(true > est)),
                         "ratio_median": float(np.median(ratio)) if ratio.size else np.nan,
                         "ratio_p10": float(np.quantile(ratio, 0.1)) if ratio.size else np.nan,
                         "substeps_median": float(np.median(sub)),
                         "us_per_row": float(1e6 * np.median(sec))})
    return rows


def markdown(rows):
    lines = ["| family | tol | answers | true > tol | worst true / tol | true > estimate | "
             "estimate / true: median (10 %) | substeps (median) | µs per row |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['family']} | {r['tol']:g} | {r['n']} | {r['violations']} | "
                     f"{r['worst']:.2g} | {r['under_estimated']} | {r['ratio_median']:.3g} "
                     f"({r['ratio_p10']:.2g}) | {r['substeps_median']:.0f} | "
                     f"{r['us_per_row']:.0f} |")
    return "\n".join(lines)


def levels_of(pots, t, q0, p0):
    """Every doubling level (relative substeps -> (q, p)) of a classical solve to tol 1e-300.

    The levels are read where :func:`~nh_operators.solvers.rows.solve_rows` computes
    them (its private ``_level``), so they are exactly the ones the rule sees."""
    seen, level = {}, solver_rows._level

    def spy(src, rows, work, interval, q0s, p0s, substeps, *args):
        out = level(src, rows, work, interval, q0s, p0s, substeps, *args)
        seen[substeps] = out
        return out

    solver_rows._level = spy
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # tol 1e-300: every level
            if isinstance(pots, list):  # formulas: one row per solve
                per = []
                for pot in pots:
                    seen.clear()
                    nh.solve(pot, t, tol=1e-300, method="classical")
                    per.append(dict(seen))
                common = sorted(set.intersection(*(set(d) for d in per)))
                return {s: tuple(np.concatenate([d[s][k] for d in per]) for k in (0, 1))
                        for s in common}
            nh.solve_many(pots, t, q0=q0, p0=p0, tol=1e-300, method="classical")
            return dict(seen)
    finally:
        solver_rows._level = level


def bound_rule(g_before, g):
    """The estimate ``solve`` uses: a bound on the coarser level of the last pair."""
    return np.maximum(g, g_before / 256.0)


def richardson_rule(safety):
    def rule(g_before, g):
        with np.errstate(divide="ignore", invalid="ignore"):
            rho = np.sqrt(g_before / g)
        rho = np.where(np.isfinite(rho), rho, 16.0)
        credit = np.where(rho >= 4.0, (np.minimum(rho, 16.0) - 1.0) ** 2, 1.0)
        return bound_rule(g_before, g) / credit * safety
    return rule


RULES = {"bound (solve's)": bound_rule, "Richardson, S = 1": richardson_rule(1.0),
         "Richardson, S = 4": richardson_rule(4.0)}


def replay(size, draws, seed, tols):
    """Per family and rule: estimate/true at the level each rule accepts."""
    rng = np.random.default_rng(seed + 1)
    runs = {}
    for name, (pots, q0, p0, truth) in families(size, seed).items():
        for _ in range(draws):
            t = np.sort(rng.uniform(0.0, 2.0, int(rng.integers(1, 21))))
            q_ref, p_ref = truth(t)
            lv = levels_of(pots, t, q0, p0)
            subs = sorted(lv)
            if len(subs) < 3:
                raise RuntimeError(f"{name}: {len(subs)} levels recorded; the replay needs "
                                   "solve_rows' _level to be called per level")
            true = np.stack([loss_per_sample(*lv[s], q_ref, p_ref)["L_tot"] for s in subs], 1)
            gaps = np.stack([0.5 * np.mean((lv[b][0] - lv[a][0]) ** 2
                                           + (lv[b][1] - lv[a][1]) ** 2, 1)
                             for a, b in zip(subs, subs[1:], strict=False)], 1)
            runs.setdefault(name, []).append((gaps, true))
    rows = []
    for name, parts in runs.items():
        for rule_name, rule in RULES.items():
            for tol in tols:
                est_all, true_all = [], []
                for gaps, true in parts:
                    n, nl = gaps.shape
                    level = np.full(n, nl - 1)
                    est = rule(gaps[:, nl - 2], gaps[:, nl - 1])
                    for k in range(nl - 1, 0, -1):  # the first level whose estimate meets tol
                        e = rule(gaps[:, k - 1], gaps[:, k])
                        level = np.where(e <= tol, k, level)
                        est = np.where(e <= tol, e, est)
                    est_all.append(est)
                    true_all.append(true[np.arange(n), level + 1])  # the finer of the pair
                est, true = np.concatenate(est_all), np.concatenate(true_all)
                moving = true > 0
                ratio = est[moving] / true[moving]
                rows.append({"family": name, "rule": rule_name, "tol": tol, "n": int(true.size),
                             "violations": int(np.sum(true > tol)),
                             "ratio_median": float(np.median(ratio)),
                             "below": float(np.mean(ratio < 1.0)),
                             "ratio_p1": float(np.quantile(ratio, 0.01))})
    return rows


def rules_markdown(rows):
    lines = ["| family | estimate | tol | answers | true > tol | estimate / true: median | "
             "estimate < true | 1 % quantile |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['family']} | {r['rule']} | {r['tol']:g} | {r['n']} | "
                     f"{r['violations']} | {r['ratio_median']:.3g} | {100 * r['below']:.0f} % "
                     f"| {r['ratio_p1']:.2g} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=100, help="potentials per family")
    ap.add_argument("--draws", type=int, default=5, help="random time sets per family")
    ap.add_argument("--seed", type=int, default=2001)
    ap.add_argument("--tols", type=float, nargs="+", default=[1e-2, 1e-4, 1e-6, 1e-8, 1e-10])
    ap.add_argument("--out", help="also write the rows as JSON (atomically)")
    ap.add_argument("--rules", action="store_true",
                    help="replay every level and compare estimate rules instead")
    ap.add_argument("--start", type=int, help="start every tol this many levels coarser "
                    "than RESOLVED_STEP (0-4; default: start_coarseness(tol))")
    args = ap.parse_args()
    if args.start is not None:
        force_start(args.start)
    if args.rules:
        rows = replay(args.size, args.draws, args.seed, args.tols)
        print(rules_markdown(rows))
        print(f"\n{device_info('cpu')['device']}, one process")
        if args.out:
            write_atomic(args.out, (json.dumps({"args": vars(args), "rows": rows}, indent=2)
                                    + "\n").encode())
        return
    rows = measure(args.size, args.draws, args.seed, args.tols)
    print(markdown(rows))
    total = sum(r["n"] for r in rows)
    print(f"\n{total} answers, {sum(r['violations'] for r in rows)} with true L_tot > tol; "
          f"{device_info('cpu')['device']}, one process")
    if args.out:
        write_atomic(args.out, (json.dumps({"args": vars(args), "rows": rows}, indent=2)
                                + "\n").encode())


if __name__ == "__main__":
    main()
