"""``solve_many(method="auto")``'s promise where the networks answer: every row within tol.

Per seed, ``--rows`` sensor-value rows of each group (Algorithm 1, the paper's
distribution, and :func:`~nh_operators.potentials.ood_potentials`), all at the 100 times of
:data:`~nh_operators.TIMES` (where the networks may answer), solved by
``nh.solve_many(V, TIMES, tol=tol)`` twice in a row (a first call and a warm one: the
pilot's memory of measured costs differs between them; the second is scored). Truth: RK4
at 2,048 substeps on the sensors' spline. Printed per group and tol: the share of rows a
network answered, the worst true L_tot / tol over all rows and over the network rows, and
the rows over tol (the promise asks none).

Run it with::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/promise/auto_contract.py \
        [--rows 3000] [--seeds 8001 8002]
"""

import argparse
import warnings

import numpy as np

import nh_operators as nh
from nh_operators.potentials import ood_potentials

TOLS = (1e-2, 1e-3, 1e-4, 1e-5)


def groups(rows: int, seed: int) -> dict[str, np.ndarray]:
    """The three groups' sensor values, (rows, 100) each."""
    spaces = {"Algorithm 1": nh.BoundedPotentialSpace(seed=seed),
              "paper": nh.BoundedPotentialSpace(seed=seed, normalization="batch",
                                                pool=int(1.25 * rows))}
    out = {k: s.potentials(s.random(rows)).V(nh.SENSORS) for k, s in spaces.items()}
    out["out of distribution"] = np.stack([p.V(nh.SENSORS) for p in ood_potentials(rows, seed)])
    return out


def main() -> None:
    """Parse the options and print the table."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--rows", type=int, default=3000)
    ap.add_argument("--seeds", type=int, nargs="+", default=[8001, 8002])
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    nh.preload()
    print("| seed | inputs | tol | by a network | worst true / tol | worst network row / tol "
          "| over tol |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for seed in args.seeds:
        for label, V in groups(args.rows, seed).items():
            q_ref, p_ref = nh.integrate_sensors(V, nh.TIMES, substeps=2048,
                                                check_resolution=False)
            for tol in TOLS:
                for _ in range(2):  # a first and a warm call
                    sol = nh.solve_many(V, nh.TIMES, tol=tol)
                true = 0.5 * (((sol.q - q_ref) ** 2).mean(1) + ((sol.p - p_ref) ** 2).mean(1))
                net = true[sol.neural].max() / tol if sol.neural.any() else 0.0
                print(f"| {seed} | {label} | {tol:g} | {sol.neural.mean():.1%} | "
                      f"{true.max() / tol:.2g} | {net:.2g} | {int((true > tol).sum())} |",
                      flush=True)


if __name__ == "__main__":
    main()
