"""The tolerance contract of ``nh.solve`` and the time it saves, measured.

For each tolerance, ``solve(potential, t, tol=tol)`` (method "auto") runs on test-set
potentials (exact B-spline curves, each at a random subset of the 100 grid times, truth =
the stored labels) and on potentials from outside the training distribution
(``nh_operators.potentials.ood`` families and the five physical potentials, each at 1-100 random
times in [0, 2], truth = DOP853 at 1e-13). Reported per group and tolerance: the share
of inputs whose true L_tot ≤ tol (the contract asks it of every call), the worst true L_tot / tol,
the share solved by a network, and the time against always calling the classical
solver at the same tolerance (means and medians per call, same run, alternating order).

Then each shipped network's estimate as a test on its own: at each tolerance, the share
of inputs it would accept (calibrated estimate ≤ tol) and the share of those accepted
whose true L_tot exceeds tol.

Run it with::

    python benchmarks/promise/solve_contract.py --test test.h5 [--n-test 1000] [--n-ood 200]
        [--preload] [--out solve_contract.json]

``--preload`` loads and runs every shipped network once before the timed calls
(:func:`nh_operators.preload`), so that no call pays for reading weights.
"""

import argparse
import json
import math
import time

import nh_operators as nh
from nh_operators.evaluation import device_info
from nh_operators.solving import contract_cases, measure_contract, network_estimates
from nh_operators.training import write_atomic


def contract_markdown(rows):
    lines = ["| inputs | tol | n | true L_tot ≤ tol | worst true / tol | by a network | "
             "auto, µs mean (median) | classical, µs mean (median) | time saved |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(
            f"| {r['group']} | {r['tol']:g} | {r['n']} | {100 * r['met']:.1f} % | "
            f"{r['worst']:.2g} | {100 * r['neural']:.1f} % | "
            f"{1e6 * r['auto_s']:.0f} ({1e6 * r['auto_median_s']:.0f}) | "
            f"{1e6 * r['classical_s']:.0f} ({1e6 * r['classical_median_s']:.0f}) | "
            f"{100 * r['saved']:+.1f} % |")
    return "\n".join(lines)


def estimate_markdown(rows):
    lines = ["| network | inputs | tol | accepted | accepted but true L_tot > tol | "
             "median true L_tot | median estimate |", "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        false = "–" if math.isnan(r["false"]) else f"{100 * r['false']:.1f} %"
        lines.append(f"| {r['network']} | {r['group']} | {r['tol']:g} | "
                     f"{100 * r['accepted']:.1f} % | {false} | {r['median_true']:.2g} | "
                     f"{r['median_estimate']:.2g} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--test", default="test.h5", help="the test set (generate --preset test)")
    ap.add_argument("--n-test", type=int, default=1000)
    ap.add_argument("--n-ood", type=int, default=200)
    ap.add_argument("--tols", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4, 1e-6, 1e-8])
    ap.add_argument("--estimate-tols", type=float, nargs="+",
                    default=[3e-1, 1e-1, 3e-2, 1e-2, 1e-3, 1e-4])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", help="write the results as JSON here (atomically)")
    ap.add_argument("--preload", action="store_true",
                    help="load and run every shipped network once first (nh.preload)")
    args = ap.parse_args()

    start = time.perf_counter()
    if args.preload:
        nh.preload()
    cases = contract_cases(args.test, args.n_test, args.n_ood, seed=args.seed)
    rows = measure_contract(cases, args.tols, progress=True)
    networks = nh.available_pretrained()
    estimates = network_estimates(cases, networks, args.estimate_tols)
    device = device_info("cpu")
    print(f"\nsolve(..., tol) on {args.n_test} test-set and {len(cases) - args.n_test} "
          f"out-of-distribution inputs; {device['device']}, load {device.get('load_average')}")
    print(contract_markdown(rows))
    print(f"\nEach network's estimate on its own ({', '.join(networks)}):")
    print(estimate_markdown(estimates))
    print(f"\n{(time.perf_counter() - start) / 60:.1f} min")
    if args.out:
        result = {"contract": rows, "estimates": estimates, "device": device,
                  "args": vars(args), "version": nh.__version__}
        write_atomic(args.out, (json.dumps(result, indent=2) + "\n").encode())


if __name__ == "__main__":
    main()
