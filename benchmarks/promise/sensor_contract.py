"""The tolerance contract on sensor values: every answer of ``solve_many`` and ``solve``
within tol of the trajectory of the sensors' spline.

Sensor values are their own potential (the not-a-knot spline through them), and since the
calibration bounds them over families of their own (``factors_sensors``,
:mod:`nh_operators.solving.acceptance`) this checks that bound on inputs it never saw:
potentials of the out-of-distribution families (a seed other than the calibration's
2719) and fresh draws of both generators, given as their 100 sensor values, each row at
its own random asked times in [0, 2] (1 to 100 of them). Truth: RK4 at 512 substeps on
the spline. Per group and tolerance: rows, the share answered by a network, the worst
true L_tot / tol and the rows over tol (the contract asks none); ``solve`` alone on the
first ``--single`` rows of each group the same way.

Run it with::

    python benchmarks/promise/sensor_contract.py [--n 2000] [--seed 3001] [--single 100]
        [--tols 1e-2 1e-3 1e-4 1e-5]
"""

import argparse
import warnings

import numpy as np

import nh_operators as nh
from nh_operators.potentials import ood_potentials

TOLS = (1e-2, 1e-3, 1e-4, 1e-5)


def groups(n, seed):
    ood = np.stack([pot.V(nh.SENSORS) for pot in ood_potentials(n, seed)])
    drawn = {}
    for label, kwargs in (("Algorithm 1", {}),
                          ("paper", {"normalization": "batch", "pool": int(1.25 * n)})):
        space = nh.BoundedPotentialSpace(seed=seed + len(drawn) + 1, **kwargs)
        drawn[label] = space.potentials(space.random(n)).V(nh.SENSORS)
    return {"out of distribution": ood, **drawn}


def asked_times(n, rng):
    """Per row, 1-100 uniform times in [0, 2], padded to 100 by repeating the last."""
    t = np.sort(rng.uniform(0.0, 2.0, (n, 100)), axis=1)
    m = rng.integers(1, 101, n)
    return np.where(np.arange(100)[None] < m[:, None], t, t[np.arange(n), m - 1][:, None])


def truth(V, t):
    q = np.empty(t.shape)
    p = np.empty(t.shape)
    for i in range(len(V)):  # each row at its own times
        qi, pi = nh.integrate_sensors(V[i:i + 1], t[i], substeps=512, check_resolution=False)
        q[i], p[i] = qi[0], pi[0]
    return q, p


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=2000, help="rows per group")
    ap.add_argument("--seed", type=int, default=3001)
    ap.add_argument("--single", type=int, default=100, help="rows of each group for solve")
    ap.add_argument("--tols", type=float, nargs="+", default=list(TOLS))
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    warnings.simplefilter("ignore")
    print("| inputs | call | tol | rows | by a network | worst true / tol | over tol |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for label, V in groups(args.n, args.seed).items():
        t = asked_times(len(V), rng)
        q_ref, p_ref = truth(V, t)
        for tol in args.tols:
            sol = nh.solve_many(V, t, tol=tol)
            true = 0.5 * (((sol.q - q_ref) ** 2).mean(1) + ((sol.p - p_ref) ** 2).mean(1))
            print(f"| {label} | solve_many | {tol:g} | {len(V)} | {sol.neural.mean():.1%} | "
                  f"{true.max() / tol:.2g} | {int((true > tol).sum())} |", flush=True)
            k = min(args.single, len(V))
            neural, worst, over = 0, 0.0, 0
            for i in range(k):
                one = nh.solve(V[i], t[i], tol=tol)
                err = 0.5 * (np.mean((one.q - q_ref[i]) ** 2) + np.mean((one.p - p_ref[i]) ** 2))
                neural += one.kind == "neural"
                worst, over = max(worst, err / tol), over + (err > tol)
            print(f"| {label} | solve | {tol:g} | {k} | {neural / k:.1%} | {worst:.2g} | "
                  f"{over} |", flush=True)


if __name__ == "__main__":
    main()
