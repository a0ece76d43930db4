"""What the maps (q0, p0) ↦ (q(t), p(t)) keep: symplecticity, reversibility, accuracy.

On potentials of a dataset with starting states (``nh-operators generate --preset
paper-states-test``), each at its own state, for the classical methods on the sensors
(Jacobian by the five-point central difference, float64) and for every ``--run`` trained with
``initial_state=True`` (Jacobian by autograd, in float64 copies of the weights):

- |det J − 1| at t = 100/99 and t = 2 (grid times; in one degree of freedom the symplectic defect
  ‖JᵀΩJ − Ω‖_F is √2 times it), median and 90 % quantile;
- the reversibility error at t = 2 (run, reverse p, run, reverse p), median;
- mean L_tot on the dataset's 100 times against its exact labels, for context.

States within 1e-3 of V0 are left out (a perturbed state must stay bounded). The exact
flow (the reference solve on the B-spline curves) is measured too, as the floor of the
differences.

Run it with::

    python benchmarks/scenes/flow_structure.py --data paper-states-test.h5 [--n 200]
        [--run RUN_DIR ...] [--eps 3e-5] [--out flow_structure.json] [--plot FILE.png]

``--plot`` draws the distribution of |det J − 1| at t = 2 of every method (log bins,
medians dashed); values below 1e-16 are drawn at 1e-16.
"""

import argparse
import json
import os

import numpy as np
import torch

import nh_operators as nh
from nh_operators.evaluation import (area_defect, device_info, flow_jacobian,
                                     loss_per_sample, network_flow, network_jacobian,
                                     plot_loss_histograms, reversibility_error, save_figure)
from nh_operators.models import cast_network
from nh_operators.solvers.rows import row_source
from nh_operators.training import load_model, write_atomic

#: Two times of the grid, t_50 ≈ 1.01 and t_99 = 2: on every method's step grid, so no
#: interpolation between steps (which is not symplectic) enters the measurement.
TIMES_ASKED = nh.TIMES[[50, 99]]
CLASSICAL = [("RK4, 1 substep", "rk4", 1), ("RK4, 4 substeps", "rk4", 4),
             ("Verlet, 4 substeps", "verlet", 4), ("Yoshida-4, 1 substep", "yoshida4", 1)]


def classical_flow(V, method, substeps, t):
    def flow(q0, p0):
        return nh.integrate_sensors(V, t, method, substeps, interval=nh.TIMES[1],
                                    check_resolution=False, q0=q0, p0=p0)
    return flow


def exact_flow(pots, t):
    return lambda q0, p0: nh.reference_solve(pots, t, q0=q0, p0=p0)


def row(name, flow, jac, q0, p0, labels):
    # a state exactly at a turning point (p0 = 0) can give a non-finite autograd
    # Jacobian (the phase's derivative there is infinite, the map's is not): left out
    # of the quantiles and counted
    defect = area_defect(jac)  # (N, 2): t = 1.01, 2
    back = reversibility_error(lambda a, b: tuple(x[:, -1:] for x in flow(a, b)), q0, p0)
    q, p = labels["full"](q0, p0)
    loss = loss_per_sample(q, p, labels["q"], labels["p"])["L_tot"]
    return {"method": name, "det_t1_median": float(np.nanmedian(defect[:, 0])),
            "det_t1_p90": float(np.nanquantile(defect[:, 0], 0.9)),
            "det_t2_median": float(np.nanmedian(defect[:, 1])),
            "det_t2_p90": float(np.nanquantile(defect[:, 1], 0.9)),
            "jacobian_nonfinite": int((~np.isfinite(defect)).any(axis=1).sum()),
            "reversibility_median": float(np.median(back)), "L_tot_mean": float(loss.mean()),
            "_defect_t2": defect[:, 1]}


def markdown(rows):
    lines = ["| method | |det J − 1| at t = 1.01: median (90 %) | at t = 2: median (90 %) | "
             "reversibility at t = 2, median | mean L_tot on [0, 2] |",
             "|---|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['det_t1_median']:.2g} ({r['det_t1_p90']:.2g}) | "
                     f"{r['det_t2_median']:.2g} ({r['det_t2_p90']:.2g}) | "
                     f"{r['reversibility_median']:.2g} | {r['L_tot_mean']:.3g} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="a dataset with states (.h5)")
    ap.add_argument("--n", type=int, default=200, help="potentials (the first n kept)")
    ap.add_argument("--run", action="append", default=[],
                    help="a run directory of a network trained with initial_state=True")
    ap.add_argument("--eps", type=float, default=3e-5, help="central-difference step")
    ap.add_argument("--out", help="also write the rows as JSON (atomically)")
    ap.add_argument("--plot", help="also draw |det J − 1| at t = 2 per method here (.png)")
    args = ap.parse_args()
    ds = nh.load_dataset(args.data)
    if ds.q0 is None:
        raise SystemExit(f"{args.data} has no starting states: generate it with "
                         "--states energy (or a -states- preset)")
    pots = ds.potentials()
    energy = 0.5 * ds.p0**2 + row_source(pots, "exact V").values_at(ds.q0[:, None])[:, 0]
    keep = np.flatnonzero(energy < nh.V0 - 1e-3)[:args.n]
    V, q0, p0, pots = ds.V[keep], ds.q0[keep], ds.p0[keep], pots[keep]
    labels = {"q": ds.q[keep], "p": ds.p[keep]}
    rows = []
    flow = exact_flow(pots, TIMES_ASKED)
    labels["full"] = exact_flow(pots, ds.t)
    rows.append(row("exact (reference solve on the curve)", flow,
                    flow_jacobian(flow, q0, p0, args.eps), q0, p0, labels))
    for name, method, substeps in CLASSICAL:
        flow = classical_flow(V, method, substeps, TIMES_ASKED)
        labels["full"] = classical_flow(V, method, substeps, ds.t)
        rows.append(row(name + " (sensors)", flow, flow_jacobian(flow, q0, p0, args.eps),
                        q0, p0, labels))
    for run in args.run:
        net, cfg = load_model(run)
        net = cast_network(net, torch.float64).eval()
        flow = network_flow(net, V, TIMES_ASKED)
        labels["full"] = network_flow(net, V, ds.t)
        rows.append(row(f"{cfg['model']} ({os.path.basename(os.path.normpath(run))})", flow,
                        network_jacobian(net, V, q0, p0, TIMES_ASKED), q0, p0, labels))
    defects = {r["method"]: np.maximum(d[np.isfinite(d)], 1e-16)
               for r in rows for d in [r.pop("_defect_t2")]}
    for r in rows:
        if r["jacobian_nonfinite"]:
            print(f"{r['method']}: {r['jacobian_nonfinite']} state(s) with a non-finite "
                  "Jacobian (at a turning point) left out of its quantiles")
    if args.plot:
        fig = plot_loss_histograms(defects, bins=40,
                                   title=f"|det J − 1| at t = 2, {keep.size} potentials")
        fig.axes[0].set_xlabel("|det J − 1| (area defect of the map (q0, p0) ↦ (q, p))")
        save_figure(fig, args.plot)
    print(markdown(rows))
    print(f"\n{keep.size} potentials of {args.data}, each at its own state; "
          f"{device_info('cpu')['device']}")
    if args.out:
        write_atomic(args.out, (json.dumps({"args": vars(args), "rows": rows}, indent=2)
                                + "\n").encode())


if __name__ == "__main__":
    main()
