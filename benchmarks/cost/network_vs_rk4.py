"""Is a shipped network faster *and* more accurate than RK4 ×1, as a user calls it? (issue 41)

For each distribution (Algorithm 1 as printed, and the paper's reference-code
distribution), ``--rows`` fresh potentials (seed ``--seed``, not a training or test seed)
at the 100 sensors, from rest, at the 100 times of :data:`~nh_operators.TIMES`. Timed in
one process, round robin (:func:`api_overhead.round_robin`), medians of ``--repeats``
rounds, µs per trajectory at batch ``--rows``, per thread setting (torch and numba both):

* ``nh.pretrained(name)(V, TIMES)`` for the distribution's PhaseONets (learned and
  quadrature start) and DeepONet;
* ``nh.integrate_sensors(V, TIMES, substeps=s, check_resolution=False)``, RK4 on the
  sensors' spline at s = 1 and 2 substeps: the classical baseline at its cheapest.

Accuracy: mean and median L_tot against the exact trajectory of each B-spline potential
(``nh.solve_many(..., tol=1e-12, method="classical")``). A network **wins** where its time
is below RK4 ×1's in the same run and both its mean and its median L_tot are below RK4
×1's.

Run it with::

    OMP_WAIT_POLICY=PASSIVE python benchmarks/cost/network_vs_rk4.py [--threads 1 2] \
        [--rows 1000] [--repeats 31] [--seed 7]
"""

import argparse
import os
import sys

import numba
import numpy as np
import torch

import nh_operators as nh

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from api_overhead import round_robin  # noqa: E402  (a sibling script)

#: Distribution → its space's options (the dataset presets' generators).
DISTRIBUTIONS = {"alg1": {}, "paper": {"normalization": "batch"}}


def draw(dist: str, rows: int, seed: int) -> nh.BoundedPotential:
    """``rows`` potentials of ``dist`` (the paper's: a pool of 1.25 · rows normalised
    together, as its presets do)."""
    options = dict(DISTRIBUTIONS[dist])
    if options:
        options["pool"] = int(1.25 * rows)
    space = nh.BoundedPotentialSpace(seed=seed, **options)
    return space.potentials(space.random(rows))


def l_tot(q: np.ndarray, p: np.ndarray, exact: nh.ManySolution) -> np.ndarray:
    """Per-row L_tot against the exact trajectories."""
    return 0.5 * (np.mean((q - exact.q) ** 2, 1) + np.mean((p - exact.p) ** 2, 1))


def main() -> None:
    """Parse the options and print one table per distribution and thread setting."""
    numba_max = numba.get_num_threads()
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("--rows", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=31)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    print(f"{args.rows} fresh potentials per distribution (seed {args.seed}), from rest, "
          f"at nh.TIMES; {args.repeats} rounds; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for dist in DISTRIBUTIONS:
        pots = draw(dist, args.rows, args.seed)
        V = pots.V(nh.SENSORS)
        exact = nh.solve_many(pots, nh.TIMES, tol=1e-12, method="classical")
        calls = {f"RK4 ×{s}": (lambda s=s, V=V: nh.integrate_sensors(
            V, nh.TIMES, substeps=s, check_resolution=False)) for s in (1, 2)}
        for name in (f"phaseonet-{dist}-quadrature", f"phaseonet-{dist}", f"deeponet-{dist}"):
            method = nh.pretrained(name)
            calls[name] = lambda m=method, V=V: m(V, nh.TIMES)
        errors = {}
        for name, fn in calls.items():
            out = fn()
            errors[name] = l_tot(*(out[:2] if isinstance(out, tuple) else (out.q, out.p)),
                                 exact)
        for threads in args.threads:
            torch.set_num_threads(threads)
            numba.set_num_threads(min(threads, numba_max))
            us = {k: 1e6 * v / args.rows for k, v in round_robin(calls, args.repeats).items()}
            base, err0 = us["RK4 ×1"], errors["RK4 ×1"]
            print(f"\n### {dist}: {threads} thread(s) (torch {torch.get_num_threads()}, "
                  f"numba {numba.get_num_threads()}), batch {args.rows}\n")
            print("| method | µs / trajectory | × RK4 ×1 | mean L_tot | median L_tot "
                  "| faster and more accurate than RK4 ×1 |")
            print("|---|---:|---:|---:|---:|---|")
            for name, err in errors.items():
                wins = (us[name] < base and err.mean() < err0.mean()
                        and np.median(err) < np.median(err0))
                verdict = "—" if name == "RK4 ×1" else ("yes" if wins else "no")
                print(f"| {name} | {us[name]:.2f} | {us[name] / base:.2f} | "
                      f"{err.mean():.2g} | {np.median(err):.2g} | {verdict} |", flush=True)


if __name__ == "__main__":
    main()
