"""Rollouts past t = 2: a stateful network fed its own state at t = 2, window after window.

On potentials of a dataset with starting states (``nh-operators generate --preset
paper-states-test``), each from its own state (q0, p0), every method produces the state
at t = 2, 4, ..., ``--horizon``:

- each ``--run`` (a network trained with ``initial_state=True`` on t ∈ [0, 2]): the
  state at t = 2 becomes the next window's starting state; with ``--project`` also the
  same with an energy projection after every window (p rescaled so that
  p²/2 + V(q) = E0, V the exact curve; q is kept); with ``--direct`` also every window
  end in one call from the first state (no rollout: for a network whose prediction is
  periodic in t, PhaseONet's);
- ``--coarse K``: RK4 and Yoshida-4 also with K times the grid's step (a cost near a
  network's);
- RK4, Verlet and Yoshida-4 on the sensors' spline, stepped the whole way;
- ``solve_many(..., tol)`` on the sensors (its classical path answers far times from one
  period).

Against the exact solution (the reference solve on the curve, the whole way): L_tot over
the window ends, the energy drift |E(t) − E0| at the horizon, the phase error there (the
time shift δt along the exact flow (p, −V′) that explains the error to first order, its
component along the trajectory over the speed²: |δt| in time units; the rest of the
error is off the orbit), and µs per trajectory for the whole horizon (this machine, one thread, the median of ``--repeats`` runs of the
batch). States within 1e-3 of V0 are left out.

Run it with::

    python benchmarks/scenes/rollout.py --data paper-states-test.h5 [--n 100]
        [--horizon 100] [--run RUN_DIR ...] [--project] [--direct] [--coarse K ...]
        [--out rollout.json]
"""

import argparse
import json
import os
import time

import numpy as np
import torch

import nh_operators as nh
from nh_operators.evaluation import device_info, loss_per_sample, project_energy
from nh_operators.solvers.rows import row_source
from nh_operators.training import load_model, write_atomic

CLASSICAL = [("RK4, 1 substep", "rk4", 1), ("RK4, 4 substeps", "rk4", 4),
             ("Verlet, 4 substeps", "verlet", 4), ("Yoshida-4, 1 substep", "yoshida4", 1)]


def network_rollout(net, V, q0, p0, windows, project=None):
    """States at the end of each window (N, windows) by feeding the state back in."""
    dtype = next(net.parameters()).dtype
    Vt = torch.as_tensor(V, dtype=dtype)
    t = torch.tensor([[2.0]], dtype=dtype)
    q, p = np.array(q0, dtype=np.float64), np.array(p0, dtype=np.float64)
    qs, ps = [], []
    with torch.no_grad():
        for _ in range(windows):
            state = torch.as_tensor(np.stack([q, p], 1), dtype=dtype)
            y = net((torch.cat([Vt, state], 1), t))[:, 0].double().numpy()
            q, p = np.clip(y[:, 0], 0.0, 1.0), y[:, 1]
            if project is not None:
                q, p = project(q, p)
            qs.append(q)
            ps.append(p)
    return np.stack(qs, 1), np.stack(ps, 1)


def network_direct(net, V, q0, p0, ends):
    """All window ends in one call from the first state: (N, windows) each."""
    dtype = next(net.parameters()).dtype
    x = torch.as_tensor(np.column_stack([V, q0, p0]), dtype=dtype)
    with torch.no_grad():
        y = net((x, torch.as_tensor(ends, dtype=dtype)[:, None])).double().numpy()
    return y[..., 0], y[..., 1]


def timed(fn, repeats):
    seconds = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        seconds.append(time.perf_counter() - start)
    return out, float(np.median(seconds))


def markdown(rows, horizon):
    lines = [f"| method | mean L_tot over t = 2, 4, …, {horizon:g} | L_tot at t = {horizon:g} | "
             f"energy drift at t = {horizon:g}: median (max) | phase error at t = {horizon:g}: "
             f"median (max) | µs per trajectory |",
             "|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['L_tot_mean']:.3g} | {r['L_tot_end']:.3g} | "
                     f"{r['drift_median']:.2g} ({r['drift_max']:.2g}) | "
                     f"{r['phase_median']:.2g} ({r['phase_max']:.2g}) | {r['us']:.0f} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="a dataset with states (.h5)")
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--horizon", type=float, default=100.0, help="a multiple of 2")
    ap.add_argument("--run", action="append", default=[])
    ap.add_argument("--project", action="store_true", help="also with energy projection")
    ap.add_argument("--direct", action="store_true",
                    help="also every window end in one call (periodic networks)")
    ap.add_argument("--coarse", type=int, action="append", default=[],
                    help="also RK4 and Yoshida-4 at K times the grid's step (repeatable)")
    ap.add_argument("--tol", type=float, default=1e-6, help="solve_many's tolerance")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out")
    args = ap.parse_args()
    torch.set_num_threads(1)
    windows = int(round(args.horizon / 2))
    if windows < 1 or abs(2 * windows - args.horizon) > 1e-9:
        raise SystemExit(f"--horizon must be a positive multiple of 2, got {args.horizon}")
    ds = nh.load_dataset(args.data)
    if ds.q0 is None:
        raise SystemExit(f"{args.data} has no starting states: generate it with "
                         "--states energy (or a -states- preset)")
    pots = ds.potentials()
    src = row_source(pots, "exact V")
    energy = 0.5 * ds.p0**2 + src.values_at(ds.q0[:, None])[:, 0]
    keep = np.flatnonzero(energy < nh.V0 - 1e-3)[:args.n]
    V, q0, p0, e0 = ds.V[keep], ds.q0[keep], ds.p0[keep], energy[keep]
    src = row_source(pots[keep], "exact V")
    ends = 2.0 * np.arange(1, windows + 1)
    q_ref, p_ref = nh.reference_solve(pots[keep], ends, q0=q0, p0=p0)

    def energy_of(q, p):
        return 0.5 * p**2 + src.values_at(np.clip(q, 0.0, 1.0))

    def project(q, p):
        qp, pp = project_energy(q[:, None], p[:, None], src.values_at, e0)
        return qp[:, 0], pp[:, 0]

    def record(name, q, p, seconds):
        loss = loss_per_sample(q, p, q_ref, p_ref)["L_tot"]
        end = 0.5 * ((q[:, -1] - q_ref[:, -1]) ** 2 + (p[:, -1] - p_ref[:, -1]) ** 2)
        drift = np.abs(energy_of(q[:, -1:], p[:, -1:])[:, 0] - e0)
        phase = np.abs(phase_error(q[:, -1], p[:, -1], q_ref[:, -1], p_ref[:, -1]))
        return {"method": name, "L_tot_mean": float(loss.mean()), "L_tot_end": float(end.mean()),
                "drift_median": float(np.median(drift)), "drift_max": float(drift.max()),
                "phase_median": float(np.median(phase)), "phase_max": float(phase.max()),
                "us": 1e6 * seconds / len(keep)}

    def phase_error(q, p, q_exact, p_exact):
        # the time shift along the exact flow (p, −V′) that best explains the error, to
        # first order: the error's component along the trajectory over its speed
        force = src.forces_at(q_exact[:, None])[:, 0]
        return ((q - q_exact) * p_exact + (p - p_exact) * force) / np.maximum(
            p_exact**2 + force**2, 1e-300)

    rows = []
    for run in args.run:
        net, cfg = load_model(run)
        net.eval()
        for proj in ([None, project] if args.project else [None]):
            (q, p), s = timed(lambda: network_rollout(net, V, q0, p0, windows, proj),
                              args.repeats)
            name = (f"{cfg['model']} ({os.path.basename(os.path.normpath(run))})"
                    + (", energy projected" if proj else ""))
            rows.append(record(name, q, p, s))
        if args.direct:
            (q, p), s = timed(lambda: network_direct(net, V, q0, p0, ends), args.repeats)
            name = f"{cfg['model']} ({os.path.basename(os.path.normpath(run))}), direct"
            rows.append(record(name, q, p, s))
    coarse = [(f"{name}, step ×{k}", method, substeps, k) for k in args.coarse
              for name, method, substeps in CLASSICAL if substeps == 1]
    for name, method, substeps, k in [c + (1,) for c in CLASSICAL] + coarse:
        (q, p), s = timed(lambda: nh.integrate_sensors(
            V, ends, method, substeps, interval=k * nh.TIMES[1], check_resolution=False,
            q0=q0, p0=p0), args.repeats)
        rows.append(record(name + " (sensors)", q, p, s))
    sol, s = timed(lambda: nh.solve_many(V, ends, q0=q0, p0=p0, tol=args.tol,
                                         method="classical"), args.repeats)
    rows.append(record(f"solve_many, tol {args.tol:g} (sensors)", sol.q, sol.p, s))
    print(markdown(rows, args.horizon))
    print(f"\n{len(keep)} potentials of {args.data}, each from its own state; one thread; "
          f"{device_info('cpu')['device']}")
    if args.out:
        write_atomic(args.out, (json.dumps({"args": vars(args), "rows": rows}, indent=2)
                                + "\n").encode())


if __name__ == "__main__":
    main()
