"""What a single ``nh.solve`` costs beside its own arithmetic (issue 41, deliverable 3).

For ``--rows`` fresh Algorithm-1 potentials as sensor values (seed 42), from rest, at the
100 times of :data:`~nh_operators.TIMES`, one thread, at each tol of ``--tols``
(µs per call, medians of ``--repeats`` passes over the rows):

* ``solve``: ``nh.solve(V, TIMES, tol=tol, method="classical")`` in a loop;
* ``its levels``: the same rows' doublings replayed through the compiled single-row
  kernel alone (:func:`nh_operators.solvers._row_doubling.double_one_row`, with the
  arguments each solve passed it): the arithmetic of every level the solve ran, with
  one dispatch;
* ``fixed step``: ``nh.integrate_sensors`` at the substeps each solve accepted, batch 1
  (the public fixed-step call for the last level alone);
* the same for three typed formulas (warm: compiled, as from their second solve on).

``--parts`` also times the pieces of one sensor solve at tol 1e-6 on their own (best of
3 × 2,000 calls each, µs): the checks, the step grids and the doubling, beside the whole
call.

Run it with::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/cost/single_solve.py \\
        [--rows 100] [--repeats 5] [--tols 1e-3 1e-6 1e-9]
"""

import argparse
import statistics
import time
import timeit

import numba
import numpy as np
import torch

import nh_operators as nh
from nh_operators.solvers import rows as rows_mod

try:
    from nh_operators.solvers import _row_doubling
except ImportError:  # a checkout before the compiled single-row doubling: solve alone
    _row_doubling = None

FORMULAS = ("2 - 8*q*(1-q)", "2 - 3*sin(pi*q)**2", "2 - 20*q**2*(1-q)**2 - 2*q*(1-q)")


def median_us(fn, repeats: int, calls: int) -> float:
    """Median over ``repeats`` of the µs per call of ``fn`` (which makes ``calls``)."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e6 * statistics.median(times) / calls


def recorded(inputs: list, tol: float) -> tuple[list, list]:
    """Solve each input once; the arguments of its compiled doubling, and its solution."""
    calls, sols = [], []
    if _row_doubling is None:
        return calls, [nh.solve(x, nh.TIMES, tol=tol, method="classical") for x in inputs]
    kernel = _row_doubling.double_one_row

    def record(*args):
        calls.append(args)
        return kernel(*args)

    rows_mod.double_one_row = record
    try:
        sols = [nh.solve(x, nh.TIMES, tol=tol, method="classical") for x in inputs]
    finally:
        rows_mod.double_one_row = kernel
    return calls, sols


def parts(v) -> None:
    """µs per call of the pieces of one sensor-value solve at tol 1e-6 (row ``v``)."""
    from nh_operators.solvers import level_grid, periodic, start_level, states
    from nh_operators.solvers._asked_order import sorted_times
    from nh_operators.solvers.classical_solve import coerce_potential
    from nh_operators.solvers.schemes import check_times

    t, tols = nh.TIMES, np.array([1e-6])
    src = rows_mod.row_source(v, "sensors")
    q0s, p0s = states.state_arrays(0.0, 0.0, 1)
    _, ts = sorted_times(t, 1)
    plan = periodic.plan_horizon(src, ts, q0s, p0s, tols, False)
    levels = start_level.start_levels(src, tols, q0s, p0s)
    pieces = {
        "coerce_potential": lambda: coerce_potential(v, None),
        "check_times": lambda: check_times(t),
        "row_source (spline)": lambda: rows_mod.row_source(v, "sensors"),
        "state_arrays + check_states": lambda: states.check_states(
            *states.state_arrays(0.0, 0.0, 1), src.values_at),
        "sorted_times": lambda: sorted_times(t, 1),
        "plan_horizon": lambda: periodic.plan_horizon(src, ts, q0s, p0s, tols, False),
        "start_levels (envelope)": lambda: start_level.start_levels(src, tols, q0s, p0s),
        "level_grid": lambda: level_grid.level_grid(src, plan, ts, True, "rk4", *levels),
        "solve_rows (all of the solver)": lambda: rows_mod.solve_rows(src, t, q0s, p0s,
                                                                      tols),
        "nh.solve": lambda: nh.solve(v, t, tol=1e-6, method="classical"),
    }
    print("\n| piece of one solve (sensors, tol 1e-6) | µs |\n|---|---:|")
    for name, fn in pieces.items():
        fn()
        best = min(timeit.repeat(fn, number=2000, repeat=3)) / 2000
        print(f"| {name} | {1e6 * best:.1f} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--rows", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--tols", type=float, nargs="+", default=[1e-3, 1e-6, 1e-9])
    parser.add_argument("--parts", action="store_true",
                        help="also time the pieces of one sensor solve")
    args = parser.parse_args()
    torch.set_num_threads(1)
    numba.set_num_threads(1)
    space = nh.BoundedPotentialSpace(seed=42)
    V = space.potentials(space.random(args.rows)).V(nh.SENSORS)
    formulas = [FORMULAS[i % len(FORMULAS)] for i in range(args.rows)]
    for f in FORMULAS:  # compiled from the second solve on
        nh.solve(f, nh.TIMES, tol=1e-3)
        nh.solve(f, nh.TIMES, tol=1e-3)
    print(f"{args.rows} rows, one thread, medians of {args.repeats}; µs per call\n")
    print("| input | tol | solve | its levels | solve / levels | fixed step at its "
          "substeps | substeps |")
    print("|---|---|---:|---:|---:|---:|---|")
    for name, inputs in (("sensors", list(V)), ("formulas", formulas)):
        for tol in args.tols:
            print(row(name, inputs, tol, V, args.repeats), flush=True)
    if args.parts:
        parts(V[0])


def row(name: str, inputs: list, tol: float, V, repeats: int) -> str:
    """One line of the table: ``inputs`` solved to ``tol``."""
    calls, sols = recorded(inputs, tol)
    n = len(inputs)
    if _row_doubling is not None and len(calls) != n:  # off the compiled path
        raise SystemExit(f"{n - len(calls)} of {n} solves did not run the compiled "
                         "single-row doubling")
    t_solve = median_us(lambda: [nh.solve(x, nh.TIMES, tol=tol, method="classical")
                                 for x in inputs], repeats, n)
    t_levels = float("nan")
    if _row_doubling is not None:
        kernel = _row_doubling.double_one_row
        t_levels = median_us(lambda: [kernel(*a) for a in calls], repeats, n)
    subs = [int(s.tried[-1]["substeps"]) for s in sols]
    fixed = ""
    if name == "sensors":
        t_fixed = median_us(lambda: [nh.integrate_sensors(
            V[i:i + 1], nh.TIMES, substeps=subs[i], check_resolution=False)
            for i in range(n)], repeats, n)
        fixed = f"{t_fixed:.0f}"
    return (f"| {name} | {tol:g} | {t_solve:.0f} | {t_levels:.0f} | {t_solve / t_levels:.1f} "
            f"| {fixed} | {sorted(set(subs))} |")

if __name__ == "__main__":
    main()
