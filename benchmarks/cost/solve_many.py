"""solve_many against looping solve and against the raw integrate_sensors kernel (issue 14).

N test-set potentials (seed 42) as sensor values, from random bounded states, at the 100
times of :data:`~nh_operators.TIMES`, tol 1e-6, ``method="classical"``. Columns, in µs per
trajectory (median of ``--repeats`` runs, all in the same run):

- ``solve_many``: the whole call (checks, spline coefficients, the substep doubling);
- ``loop solve``: ``nh.solve`` row by row (timed on at most ``--loop-cap`` rows);
- ``kernel``: :func:`~nh_operators.integrate_sensors`, each row at the substeps that
  solve_many ended with for it (one call per distinct value), without resolution checks:
  the cost of the last level alone;
- the ratios loop / solve_many (goal ≥ 20 at N = 10⁴) and solve_many / kernel (goal ≤ 2).

``--inputs bspline`` runs the same table on the exact potentials themselves (a batched
:class:`~nh_operators.BoundedPotential`), the generator's B-spline curves, which solve
integrates with RK4 in the curve parameter λ (no inversion of q(λ) = x per force); the
kernel column is then that kernel (``nh_operators.solvers._curve_fixed``), and
``--q-kernel`` adds, for comparison, :func:`~nh_operators.integrate` (RK4 in q,
whose force inverts q(λ) = x by Newton's method at every evaluation) at the same substeps.

Then the formula speed-up: ``nh.solve`` of a typed formula (compiled) against the same
formula as a plain Python callable, and against a B-spline, at batch 1.

Run it with::

    python benchmarks/cost/solve_many.py [--sizes 1 100 10000 100000] [--repeats 3] \
        [--inputs sensors|bspline] [--q-kernel] [--formulas | --no-formulas]
"""

import argparse
import statistics
import time

import numpy as np

import nh_operators as nh
from nh_operators.potentials import BoundedPotentialSpace


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def states(V, rng):
    q0 = rng.uniform(0.05, 0.95, len(V))
    room = 2.0 - np.array([np.interp(q, nh.SENSORS, v) for q, v in zip(q0, V)])
    p0 = rng.choice([-1, 1], len(V)) * np.sqrt(2 * room * rng.uniform(0, 0.9, len(V)))
    return q0, p0


def curve_kernel(pots, t, substeps, check_resolution, q0, p0):
    """solve's kernel for B-spline rows: RK4 in the curve parameter on the even grid t."""
    from nh_operators.solvers import _curve_fixed

    n = pots.params.shape[0]
    oq, op = np.empty((n, t.size)), np.empty((n, t.size))
    steps = (t.size - 1) * substeps
    _curve_fixed.curve_rows_fixed(pots.params, np.arange(n), t, t[-1] / steps, steps, oq, op,
                                  q0, p0)
    return oq, op


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 100, 10_000, 100_000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--loop-cap", type=int, default=300)
    parser.add_argument("--tol", type=float, default=1e-6)
    parser.add_argument("--inputs", choices=("sensors", "bspline"), default="sensors")
    parser.add_argument("--q-kernel", action="store_true",
                        help="bspline: also time RK4 in q (nh.integrate) at the same substeps")
    parser.add_argument("--formulas", action=argparse.BooleanOptionalAction, default=True,
                        help="also the batch-1 formula table")
    args = parser.parse_args()
    rng = np.random.default_rng(14)
    space = BoundedPotentialSpace(seed=42)
    pots = space.potentials(space.random(max(args.sizes)))
    V_sensors = pots.V(nh.SENSORS)
    q_all, p_all = states(V_sensors, rng)
    V_all = V_sensors if args.inputs == "sensors" else pots
    fixed = nh.integrate_sensors if args.inputs == "sensors" else curve_kernel
    nh.solve_many(V_all[:2], nh.TIMES, q0=q_all[:2], p0=p_all[:2], tol=args.tol,
                  method="classical")  # compile
    fixed(V_all[:2], nh.TIMES, substeps=2, check_resolution=False, q0=q_all[:2], p0=p_all[:2])
    what = "sensor values" if args.inputs == "sensors" else "B-spline curves (exact)"
    print(f"{what}, random bounded states, 100 times on [0, 2], tol {args.tol:g}; "
          "µs per trajectory\n")
    q_col = f" {'RK4 in q':>9}" if args.q_kernel else ""
    print(f"{'N':>7} {'solve_many':>11} {'loop solve':>11} {'kernel':>9}{q_col} "
          f"{'subst med/max':>13} {'loop/many':>10} {'many/kernel':>12}")
    for n in args.sizes:
        V, q0, p0 = V_all[:n], q_all[:n], p_all[:n]
        out = {}

        def many():
            out["sol"] = nh.solve_many(V, nh.TIMES, q0=q0, p0=p0, tol=args.tol,
                                       method="classical", progress=False)

        t_many = median_time(many, args.repeats) / n
        k = min(n, args.loop_cap)
        t_loop = median_time(lambda: [nh.solve(V[i], nh.TIMES, q0=q0[i], p0=p0[i],
                                               tol=args.tol, method="classical")
                                      for i in range(k)], 1) / k
        subs = out["sol"].substeps

        def kernel(V=V, q0=q0, p0=p0, subs=subs, fixed=fixed):
            for sub in np.unique(subs):  # each row at the substeps it ended with
                rows = subs == sub
                fixed(V[np.flatnonzero(rows)], nh.TIMES, substeps=int(sub),
                      check_resolution=False, q0=q0[rows], p0=p0[rows])

        t_kernel = median_time(kernel, args.repeats) / n
        q_cell = ""
        if args.q_kernel:
            t_q = median_time(lambda: kernel(fixed=nh.integrate), args.repeats) / n
            q_cell = f" {1e6 * t_q:9.1f}"
        print(f"{n:>7} {1e6 * t_many:11.1f} {1e6 * t_loop:11.1f} {1e6 * t_kernel:9.1f}{q_cell} "
              f"{int(np.median(subs)):>5}/{subs.max():<4} {t_loop / t_many:10.1f} "
              f"{t_many / t_kernel:12.2f}")
    if args.formulas:
        formulas(space)


def formulas(space):
    print("\nformula speed-up at batch 1 (nh.solve, tol 1e-8, 100 times, median of 20)")
    text = "625/8*(q-0.2)**2*(q-0.8)**2"
    pot = nh.PHYSICAL_POTENTIALS["double_well"]

    def as_python(q):
        return pot.V(q)

    bspline = space.potentials(space.random(1))[0]
    rows = {"typed formula (compiled)": text,
            "same formula as a Python callable": (as_python, pot.dV),
            "B-spline (generator potential)": bspline}
    base = None
    for label, what in rows.items():
        if isinstance(what, tuple):
            fn = lambda w=what: nh.solve(w[0], nh.TIMES, tol=1e-8, dV=w[1])
        else:
            fn = lambda w=what: nh.solve(w, nh.TIMES, tol=1e-8)
        fn()
        seconds = median_time(fn, 20)
        base = base or seconds
        print(f"  {label:<36} {1e3 * seconds:8.3f} ms  ({seconds / base:.2f}× the formula)")


if __name__ == "__main__":
    main()
