"""The wall rule of a network's domain (``min_wall_force``), measured.

For each dataset file given, the weakest inward wall force of its potentials
(:func:`~nh_operators.potentials.wall_forces`: -V'(0) and V'(1) from the cubic through
the four sensors at each wall); then, of ``--n-ood`` out-of-distribution potentials
(:func:`~nh_operators.potentials.ood_potentials`, the calibration's seed 2719), how many
have a wall that does not push inward (force ≤ 0) or pushes less than the generator's
bound, per family; and, for one shipped network, on those its domain admits but for the
wall rule, given as sensor values and asked at the whole grid and at single times, the
largest true L_tot over the calibrated estimate (truth: RK4 at 512 substeps on the
sensors' spline): what the rule keeps from the network.

Run it with::

    python benchmarks/promise/domain_walls.py --data paper-extended.h5 alg1-extended.h5 \
        [--model phaseonet-paper] [--n-ood 600]
"""

import argparse
import collections
import warnings

import numpy as np

import nh_operators as nh
from nh_operators.data import load_dataset
from nh_operators.potentials import GENERATOR_DOMAIN, in_domain, ood_potentials, wall_forces
from nh_operators.solving import InputKind, load, network_domain
from nh_operators.solving.network_pass import neural_raw


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", nargs="*", default=[], help="dataset files (.h5)")
    ap.add_argument("--model", default="phaseonet-paper")
    ap.add_argument("--n-ood", type=int, default=600)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    print("| data | potentials | weakest wall force |\n|---|---:|---:|")
    for path in args.data:
        V = np.asarray(load_dataset(path).V)
        print(f"| {path} | {len(V)} | {wall_forces(V).min():.3g} |")
    pots = ood_potentials(args.n_ood, 2719)
    V = np.stack([p.V(nh.SENSORS) for p in pots])
    walls = wall_forces(V).min(axis=1)
    bound = GENERATOR_DOMAIN["min_wall_force"]
    outward = collections.Counter(p.name for p, w in zip(pots, walls) if w <= 0)
    weak = collections.Counter(p.name for p, w in zip(pots, walls) if 0 < w < bound)
    print(f"\n{args.n_ood} out-of-distribution potentials: {sum(outward.values())} with a wall "
          f"that does not push inward ({dict(outward)}), {sum(weak.values())} more below "
          f"{bound:.3g} ({dict(weak)})")
    domain = dict(network_domain(args.model))
    rule = domain.pop("min_wall_force")
    caught = np.flatnonzero(in_domain(V, domain) & (walls < rule))
    cal = load(args.model).calibration
    worst = (0.0, None, None, 0.0)  # ratio, family, times, true L_tot
    for i in caught:
        for t in (nh.TIMES, np.array([0.4]), np.array([0.8]), np.array([1.6])):
            q, p, raw = neural_raw(args.model, V[i], "sensors", t)
            q_ref, p_ref = nh.integrate_sensors(V[i], t, substeps=512, check_resolution=False)
            true = 0.5 * (np.mean((q - q_ref) ** 2) + np.mean((p - p_ref) ** 2))
            ratio = true / float(cal.calibrated_calls(raw, InputKind.SENSORS,
                                                      t.max() <= 0.5))
            if ratio > worst[0]:
                worst = (ratio, pots[i].name, t.max() if t.size == 1 else "the grid", true)
    print(f"{args.model}: {caught.size} of them inside its domain but for the wall rule; "
          f"the largest true / calibrated estimate among them: {worst[0]:.3g} "
          f"({worst[1]}, at t = {worst[2]}, true L_tot {worst[3]:.2g})")


if __name__ == "__main__":
    main()
