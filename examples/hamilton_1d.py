"""Random bounded potentials, exact labels and the classical baselines, in seconds on a CPU.

Run: ``python examples/hamilton_1d.py [--size 200] [--seed 0]``. Draws potentials with the
paper's generator, labels them exactly, and compares the classical solvers that see only
the 100 sensor values (as a neural operator does) with those labels. The neural part of
the pipeline joins this script once the networks land.
"""

import argparse
import time

import numpy as np

import nh_operators as nh
from nh_operators.data import generate_dataset
from nh_operators.evaluate import loss_per_sample


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=200, help="number of potentials")
    parser.add_argument("--seed", type=int, default=0, help="generator seed")
    args = parser.parse_args(argv)

    ds = generate_dataset(args.size, args.seed, progress=False)
    print(f"{len(ds)} potentials, {ds.attrs['n_dropped']} dropped; n_GRF counts:",
          dict(zip(*np.unique(ds.n_grf, return_counts=True))))
    print(f"\n{'method':<26}{'mean L_tot':>12}{'median':>12}{'ms total':>10}")
    runs = {f"rk4, {k} substeps": (lambda k=k: nh.integrate_sensors(ds.V, ds.t, "rk4", k))
            for k in (1, 4, 16)}
    runs["yoshida8, 2 substeps"] = lambda: nh.integrate_sensors(ds.V, ds.t, "yoshida8", 2)
    runs["paper replica RK4"] = lambda: nh.paper_rk4(ds.V, ds.t)
    for name, run in runs.items():
        run()  # compile / warm up
        start = time.perf_counter()
        q, p = run()
        ms = 1e3 * (time.perf_counter() - start)
        loss = loss_per_sample(q, p, ds.q, ds.p)["L_tot"]
        print(f"{name:<26}{loss.mean():>12.3e}{np.median(loss):>12.3e}{ms:>10.1f}")


if __name__ == "__main__":
    main()
