"""How well a network's raw estimate bounds its error, by the horizon of the call.

For one shipped network, the calibration's families (:func:`~nh_operators.solving.
calibration_families`: its own distribution, the other generator's, the
out-of-distribution families, each as exact potentials and as sensor values) are drawn
again with every call's latest time in one class: up to 0.1, 0.1 to 0.5, 0.5 to 2
(log-uniform) and exactly 2. Per class and family, the 99.9 % quantile and the largest
true L_tot / raw estimate. A class where they are far above the others' needs factors of
its own: this is why calls up to ``EARLY_HORIZON`` = 0.5 are calibrated apart
(:mod:`nh_operators.solving.acceptance`).

Run it with::

    python benchmarks/promise/estimate_horizons.py --model phaseonet-paper \
        --data calib-paper.h5 --other other-alg1.h5 [--n-ood 200]
"""

import argparse
import warnings

import numpy as np

from nh_operators.data import load_dataset
from nh_operators.solving import samples

CLASSES = (("t ≤ 0.1", 0.02, 0.1), ("0.1 < t ≤ 0.5", 0.1, 0.5), ("0.5 < t < 2", 0.5, 2.0),
           ("t = 2", 2.0, 2.0))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", required=True)
    ap.add_argument("--data", required=True, help="the calibration set of its distribution")
    ap.add_argument("--other", help="the other generator's potentials (.h5)")
    ap.add_argument("--n-ood", type=int, default=200)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    data = load_dataset(args.data)
    other = load_dataset(args.other).potentials() if args.other else None
    rows = []
    for label, lo, hi in CLASSES:
        def asked(rng, lo=lo, hi=hi):  # the latest asked time log-uniform in [lo, hi]
            m = 1 if rng.random() < 0.3 else int(rng.integers(2, 101))
            return rng.uniform(0.0, float(np.exp(rng.uniform(np.log(lo), np.log(hi)))), m)

        samples._asked_times = asked
        fams = samples.calibration_families(args.model, data, other=other, n_ood=args.n_ood)
        for fam, (true, raw, *_) in fams.items():
            if true.size:
                ratio = true / np.maximum(raw, 1e-300)
                rows.append((label, fam, true.size, np.quantile(ratio, 0.999), ratio.max()))
    print(f"{args.model}: true L_tot / raw estimate by the latest asked time of a call")
    print("| calls | family | samples | 99.9 % quantile | largest |\n|---|---|---:|---:|---:|")
    for label, fam, n, q, top in rows:
        print(f"| {label} | {fam} | {n} | {q:.3g} | {top:.3g} |")


if __name__ == "__main__":
    main()
