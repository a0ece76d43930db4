"""``solve_many`` on scenes from random states: what the networks that read a state save.

N potentials of a dataset with starting states (``nh-operators generate --preset
paper-states-test``), each from its own state, at one random set of 20 times in [0, 2]
per tolerance; as exact B-splines and as sensor values. For each tolerance, in the same
run: ``solve_many(..., method="auto")`` against ``method="classical"`` (µs per row,
median of ``--repeats``), the share of rows a network answered, and the largest true
L_tot / tol of the auto answers (truth: the reference solve on the curve for B-splines,
RK4 at 512 substeps on the sensors' spline for sensor values — each input's own truth).

Run it with::

    python benchmarks/scenes/state_routing.py --data paper-states-test.h5 [--n 1000]
        [--tols 1e-2 1e-3 1e-4] [--repeats 3] [--out routing.json]
"""

import argparse
import json
import time

import numpy as np

import nh_operators as nh
from nh_operators.evaluation import device_info, loss_per_sample
from nh_operators.training import write_atomic


def timed(fn, repeats):
    seconds, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        seconds.append(time.perf_counter() - start)
    return out, float(np.median(seconds))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="a dataset with states (.h5)")
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--tols", type=float, nargs="+", default=[1e-2, 1e-3, 1e-4])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0, help="seed of the asked times")
    ap.add_argument("--out")
    args = ap.parse_args()
    ds = nh.load_dataset(args.data)
    if ds.q0 is None:
        raise SystemExit(f"{args.data} has no starting states (generate it with a -states- "
                         "preset)")
    n = min(args.n, len(ds))
    pots, V, q0, p0 = ds.potentials()[:n], np.asarray(ds.V[:n]), ds.q0[:n], ds.p0[:n]
    rng = np.random.default_rng(args.seed)
    rows = []
    nh.solve_many(V[:8], [0.5], q0=q0[:8], p0=p0[:8], tol=1e-3)  # load the networks
    for tol in args.tols:
        t = np.sort(rng.uniform(0.0, 2.0, 20))
        for kind, inputs in (("B-spline", pots), ("sensors", V)):
            if kind == "B-spline":
                truth = nh.reference_solve(pots, t, q0=q0, p0=p0)
            else:
                truth = nh.integrate_sensors(V, t, substeps=512, check_resolution=False,
                                             q0=q0, p0=p0)
            auto, s_auto = timed(lambda: nh.solve_many(inputs, t, q0=q0, p0=p0, tol=tol),
                                 args.repeats)
            _, s_cls = timed(lambda: nh.solve_many(inputs, t, q0=q0, p0=p0, tol=tol,
                                                   method="classical"), args.repeats)
            true = loss_per_sample(auto.q, auto.p, *truth)["L_tot"]
            rows.append({"input": kind, "tol": tol, "us_auto": 1e6 * s_auto / n,
                         "us_classical": 1e6 * s_cls / n, "speedup": s_cls / s_auto,
                         "neural_share": float(auto.neural.mean()),
                         "networks": sorted(set(auto.methods[auto.neural].tolist())),
                         "worst_true_over_tol": float((true / tol).max())})
    print("| input | tol | µs per row, auto | classical | classical / auto | answered by a "
          "network | worst true / tol |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['input']} | {r['tol']:g} | {r['us_auto']:.0f} | {r['us_classical']:.0f} | "
              f"{r['speedup']:.2f} | {r['neural_share']:.1%} "
              f"({', '.join(r['networks']) or 'none'}) | {r['worst_true_over_tol']:.3g} |")
    print(f"\n{n} potentials of {args.data}, each from its own state; 20 random times per "
          f"tolerance; {device_info('cpu')['device']}")
    if args.out:
        write_atomic(args.out, (json.dumps({"args": vars(args), "rows": rows}, indent=2)
                                + "\n").encode())


if __name__ == "__main__":
    main()
