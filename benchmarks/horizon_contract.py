"""The horizon contract of issue 14: any time at the cost of one period, to tolerance.

For each tolerance (1e-4, 1e-6, 1e-8) and horizon (2 ... 1e6), ``nh.solve`` (classical,
as ``auto`` is for these inputs) runs on the five physical potentials and on test-set
B-spline potentials, from (0, 0) and from random bounded states, at 20 times spread over
[0, horizon] (the last one at the horizon). Truth: the exact solution for the SHO and
MFF (any state); otherwise a Yoshida-8 solve at tol 1e-13 at the reduced time
r = t mod T, with the solve's own period T (the periods themselves are checked against
30-digit mpmath quadrature in tests/solvers/test_periodic.py, so for these rows the table
checks the reduction and the integration, not T independently).

Reported per (tol, horizon): the share of cases whose true L_tot ≤ tol (a case that
raises :class:`~nh_operators.solvers.PeriodError`, a refusal the contract allows, is counted
apart and named), the worst ratio
true / tol, and the median, 90th percentile and maximum over the cases of (time at this
horizon) / (time of the same solve on [0, 2]), measured in the same run: the two solves
are called in turn ``--repeats`` times (default 9) and their medians compared, so that the
noise of a shared machine hits both alike.

Run it with::

    python benchmarks/horizon_contract.py [--size 20] [--horizons 2 100 1e4 1e6] [--repeats 9]
"""

import argparse
import math
import statistics
import time

import numpy as np

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample
from nh_operators.potentials import BoundedPotentialSpace
from nh_operators.solvers import PeriodError


def reference(pot, q0, p0, t, period):
    """Truth at t: the high-accuracy solve at t mod T (T checked against DOP853 below)."""
    r = t if not math.isfinite(period) else t - np.floor(t / period) * period
    if isinstance(pot, str) and pot == "sho":
        return nh.PHYSICAL_POTENTIALS["sho"].exact(t, q0, p0)
    if pot is nh.PHYSICAL_POTENTIALS["mff"]:
        return nh.PHYSICAL_POTENTIALS["mff"].exact(t, q0, p0)
    sol = nh.solve(pot, r, tol=1e-13, method="yoshida8", q0=q0, p0=p0)
    return sol.q, sol.p


def paired(short, long, repeats):
    """Median times of ``short()`` and ``long()``, called in turn (noise hits both alike),
    and the last output of ``long``; a PeriodError of ``long`` propagates."""
    times = ([], [])
    for _ in range(repeats):
        for k, fn in enumerate((short, long)):  # long last: ``out`` is its output
            start = time.perf_counter()
            out = fn()
            times[k].append(time.perf_counter() - start)
    return statistics.median(times[0]), statistics.median(times[1]), out


def cases(size, rng):
    pots = BoundedPotentialSpace.potentials(BoundedPotentialSpace(seed=42).random(size))
    items = [(name, nh.PHYSICAL_POTENTIALS[name]) for name in nh.PHYSICAL_POTENTIALS]
    items = [("sho", "sho")] + items[1:] + [(f"test[{i}]", pots[i]) for i in range(size)]
    out = []
    for label, pot in items:
        out.append((label, pot, 0.0, 0.0))
        V = pot if not isinstance(pot, str) else nh.PHYSICAL_POTENTIALS[pot]
        q0 = float(rng.uniform(0.1, 0.9))
        room = 2.0 - float(V.V(q0))
        p0 = float(rng.choice([-1, 1]) * math.sqrt(2 * room * rng.uniform(0.05, 0.9)))
        out.append((label, pot, q0, p0))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--size", type=int, default=20, help="test-set potentials")
    parser.add_argument("--horizons", type=float, nargs="+", default=[2, 100, 1e4, 1e6])
    parser.add_argument("--tols", type=float, nargs="+", default=[1e-4, 1e-6, 1e-8])
    parser.add_argument("--repeats", type=int, default=9,
                        help="timings per case and horizon, alternating with [0, 2]")
    args = parser.parse_args()
    rng = np.random.default_rng(14)
    items = cases(args.size, rng)
    nh.solve("sho", [3.0], tol=1e-6)  # compile
    print(f"{len(items)} cases (5 physical + {args.size} test-set potentials, each from "
          "(0, 0) and from a random bounded state), 20 times on [0, horizon]\n")
    print(f"{'tol':>7} {'horizon':>8} {'met':>8} {'worst L/tol':>12} "
          f"{'time / [0,2]: median':>21} {'p90':>6} {'max':>6} {'refused':>8}")
    for tol in args.tols:
        for horizon in args.horizons:
            met, worst, ratios, refused = 0, 0.0, [], []
            for label, pot, q0, p0 in items:
                t = np.linspace(0, horizon, 20)
                short = np.linspace(0, 2, 20)
                def run(times, pot=pot, q0=q0, p0=p0):
                    return nh.solve(pot, times, tol=tol, q0=q0, p0=p0)

                try:
                    base, seconds, sol = paired(lambda: run(short), lambda: run(t),
                                                args.repeats)
                except PeriodError as err:  # a clear refusal, not a wrong answer
                    refused.append(f"{label} ({q0:.2g}, {p0:.2g}): {err}")
                    continue
                period = sol.tried[-1].get("period") or math.inf
                q, p = reference(pot, q0, p0, t, period)
                true = float(loss_per_sample(sol.q, sol.p, q, p)["L_tot"])
                met += true <= tol
                worst = max(worst, true / tol)
                ratios.append(seconds / base)
            print(f"{tol:7.0e} {horizon:8.0e} {met:>4}/{len(items):<3} {worst:12.3g} "
                  f"{statistics.median(ratios):21.2f} {np.quantile(ratios, 0.9):6.2f} "
                  f"{max(ratios):6.2f} {len(refused):>8}")
            for line in refused:
                print(f"{'':17}refused: {line}")


if __name__ == "__main__":
    main()
