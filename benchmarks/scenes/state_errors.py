"""Where a state network's error is (issue 26): per-row L_tot on a test set with states.

For a shipped network that reads a state (default ``phaseonet-paper-states``) on a test
set with states (``--data``, e.g. ``paper-states-test.h5``), at the 100 times of
:data:`~nh_operators.TIMES`, float32 as shipped:

- the mean and median L_tot, on the rows the generator drew near a separatrix
  (``near_separatrix``) and on the others, and the share of the mean carried by the worst
  1 % and 10 % of rows;
- RK4 on the sensors at 64 substeps on the same rows: what the 100 sensors allow (the
  information floor), so that a gap is the network's and not the sensors';
- for a PhaseONet, on the worst ``--worst`` rows: the relative error of its period T
  (quadrature on the sensor spline) against the classical orbit solver's
  (:func:`~nh_operators.solvers.periodic.orbit_periods`, to about 1e-14) on the same
  spline, and whether the turning points agree: if they do, the error is in the learned
  shape in phase.

``--model`` may be given more than once (a shipped name or a run directory; the worst
rows are those of the first); ``--computed`` adds PhaseONet's computed shape with no
learned correction (``shape="quadrature"`` at its construction, float32);
``--validation`` scores the validation split of a training set instead of a whole file;
``--project`` adds each network's output put back on its energy
(:func:`~nh_operators.evaluation.project_energy`, energy and V from the sensor spline:
what a user of the network has).

Run it with::

    python benchmarks/scenes/state_errors.py --data paper-states-test.h5 \\
        [--model phaseonet-paper-states] [--computed] [--worst 200]
"""

import argparse

import numpy as np
import torch

import nh_operators as nh
from nh_operators.data import load_dataset
from nh_operators.evaluation import project_energy
from nh_operators.models import StatePhaseONet
from nh_operators.training import load_model
from nh_operators.solvers.periodic import orbit_periods
from nh_operators.solvers.rows import row_source


class Truth:
    """The labels of the scored rows."""

    def __init__(self, q, p):
        self.q, self.p = np.asarray(q), np.asarray(p)


def _network(name):
    """A shipped model's network (eval mode, float32), or a run directory's."""
    if name in nh.available_pretrained():
        return nh.pretrained(name).net
    return load_model(name)[0].eval()


def l_tot(q, p, ds):
    return 0.5 * (((q - ds.q) ** 2).mean(axis=1) + ((p - ds.p) ** 2).mean(axis=1))


def summary(name, L, near):
    order = np.sort(L)[::-1]
    k1, k10 = max(1, L.size // 100), max(1, L.size // 10)
    print(f"| {name} | {L.mean():.3g} | {np.median(L):.3g} | {L[near].mean():.3g} | "
          f"{L[~near].mean():.3g} | {order[:k1].sum() / L.sum():.0%} | "
          f"{order[:k10].sum() / L.sum():.0%} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--data", required=True, help="a labelled test set with states (.h5)")
    ap.add_argument("--model", action="append",
                    help="a shipped model or a run directory (repeatable; default "
                         "phaseonet-paper-states)")
    ap.add_argument("--computed", action="store_true",
                    help="also PhaseONet's computed shape without a learned correction")
    ap.add_argument("--validation", action="store_true",
                    help="score the validation split of --data (a training set)")
    ap.add_argument("--project", action="store_true",
                    help="also each network's output put back on its energy")
    ap.add_argument("--worst", type=int, default=200)
    args = ap.parse_args()
    torch.set_num_threads(1)
    ds = load_dataset(args.data)
    if ds.q0 is None:
        raise SystemExit(f"{args.data} holds no states (generate a -states- preset)")
    rows = ds.split_indices()[1] if args.validation else np.arange(len(ds))
    V, q0, p0 = (np.asarray(a)[rows] for a in (ds.V, ds.q0, ds.p0))
    near = np.asarray(ds.near_separatrix)[rows].astype(bool)
    truth = Truth(ds.q[rows], ds.p[rows])
    names = args.model or ["phaseonet-paper-states"]
    nets = [(name, _network(name)) for name in names]
    if args.computed:
        torch.manual_seed(0)   # the last layer is zero: the seed does not matter
        nets.append(("computed shape, no learned correction",
                     StatePhaseONet(shape="quadrature").eval()))
    x = torch.tensor(np.c_[V, q0, p0], dtype=torch.float32)  # the networks as shipped
    losses, projected = [], []
    src = row_source(V, "sensors")
    energy_spline = 0.5 * p0**2 + src.values_at(q0[:, None])[:, 0]
    for _, net in nets:
        with torch.no_grad():
            y = torch.cat([net((x[i:i + 4096], torch.tensor(nh.TIMES[:, None],
                                                            dtype=torch.float32)))
                           for i in range(0, len(x), 4096)])
        y = y.numpy().astype(np.float64)
        losses.append(l_tot(y[..., 0], y[..., 1], truth))
        if args.project:
            projected.append(l_tot(*project_energy(y[..., 0], y[..., 1], src.values_at,
                                                   energy_spline), truth))
    # RK4 runs on the rows whose state is bounded in the sensor spline too (a state just
    # below V0 in the true potential can sit above it in the spline)
    ok = energy_spline <= 2.0
    q_s, p_s = np.full((len(V), len(nh.TIMES)), np.nan), np.full((len(V), len(nh.TIMES)), np.nan)
    q_s[ok], p_s[ok] = nh.integrate_sensors(V[ok], nh.TIMES, substeps=64, q0=q0[ok],
                                            p0=p0[ok], check_resolution=False)
    what = "validation split" if args.validation else "all rows"
    print(f"{args.data} ({what}): {len(V)} rows, {near.mean():.1%} drawn near a "
          f"separatrix\n")
    print("| method | mean | median | mean near a separatrix | mean elsewhere | "
          "worst 1 % carry | worst 10 % carry |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for (name, _), L in zip(nets, losses):
        summary(name, L, near)
    for (name, _), L in zip(nets, projected):
        summary(f"{name}, energy projected", L, near)
    rk4 = l_tot(q_s, p_s, truth)
    if ok.all():
        summary("RK4 on the sensors, 64 substeps", rk4, near)
    else:
        summary(f"RK4 on the sensors, 64 substeps ({(~ok).sum()} rows left out: the state "
                f"is above V0 in the sensor spline)", rk4[ok], near[ok])
    L, net = losses[0], nets[0][1]
    if not hasattr(net, "state_orbit"):
        return
    worst = np.argsort(L)[::-1][:args.worst]
    with torch.no_grad():
        orbit = net.state_orbit(torch.tensor(np.c_[V, q0, p0][worst]))
    out, status = orbit_periods(row_source(V[worst], "sensors"), np.arange(worst.size),
                                q0[worst], p0[worst])
    ok = status == 0
    rel = np.abs(orbit["T"].numpy() / out[:, 0] - 1)[ok]
    ends = np.maximum(np.abs(orbit["a"].numpy() - out[:, 2]),
                      np.abs(orbit["b"].numpy() - out[:, 3]))[ok]
    print(f"\nworst {worst.size} rows (L_tot {L[worst].min():.2g} to {L[worst].max():.2g}; "
          f"{near[worst].mean():.0%} near a separatrix; orbit solver found {ok.sum()}): "
          f"period relative error median {np.median(rel):.2g}, 90 % {np.quantile(rel, 0.9):.2g},"
          f" max {rel.max():.2g}; turning points differ by at most {ends.max():.2g}")


if __name__ == "__main__":
    main()
