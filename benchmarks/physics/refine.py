"""Is test-time refinement ever worth it? (issue 43 §3)

For each potential (the five physical ones, ``--ood`` out-of-distribution ones from
``nh_operators.potentials.ood_potentials``, MFF among the physical) and each network
(shipped names, or run directories of ``nh.train``), the table gives:

* the network's L_tot against a reference solve (``nh.reference_solve``) and its time;
* the same after ``nh.refine(net, potential, steps=..., ...)`` (V' from a spline of
  1,000 samples of the potential), with the refinement's wall time and its residual
  before and after;
* the classical solver asked for the refined accuracy:
  ``nh.solve_classical(potential, nh.TIMES, tol=<refined L_tot>)``, its wall time (best
  of ``--repeat``) and its L_tot.

With ``--optimizer newton`` the refinement is ``nh.refine(net, potential,
method="newton", tol=--tol)``: the network's trajectory is the first guess of a Chebyshev
collocation solve driven by Newton's method (the weights are not touched); its time is the
best of ``--repeat`` (network forward included), and two more columns say whether it
converged and what the same Newton solve reaches from the guess q ≡ 0 instead of the
network's (what the network's guess is worth).

The refinement is worth it where it lowers the error *and* costs less than the classical
solver at that error; the last column says which.

Run it (one thread)::

    OMP_NUM_THREADS=1 python benchmarks/physics/refine.py --networks deeponet-paper \\
        --optimizer adam --steps 500 --lr 1e-4 --ood 4
    OMP_NUM_THREADS=1 python benchmarks/physics/refine.py --networks deeponet-paper \\
        --optimizer newton --tol 1e-10 --ood 4
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import torch

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample, time_call
from nh_operators.potentials import ood_potentials
from nh_operators.solvers import collocate
from nh_operators.training import load_model


def network(name: str) -> tuple[str, torch.nn.Module]:
    """A shipped network's name, or a run directory (label: its last two path parts)."""
    if Path(name).is_dir():
        return "/".join(Path(name).parts[-2:]), load_model(name)[0]
    return name, nh.pretrained(name).net


def l_tot(q: np.ndarray, p: np.ndarray, ref: tuple[np.ndarray, np.ndarray]) -> float:
    return float(loss_per_sample(q, p, ref[0], ref[1])["L_tot"])


def best_time(call, repeat: int) -> float:
    return min(time_call(call, repeats=repeat, warmup=0))


def row(label: str, potential, net: torch.nn.Module, args: argparse.Namespace) -> dict:
    ref = nh.reference_solve(potential, nh.TIMES)
    ref = (np.asarray(ref[0]).reshape(-1), np.asarray(ref[1]).reshape(-1))
    V = torch.tensor(potential.V(nh.SENSORS)[None], dtype=next(net.parameters()).dtype)
    t = torch.tensor(nh.TIMES[:, None], dtype=V.dtype)
    with torch.no_grad():
        y = net.eval()((V, t))[0].double().numpy()
    before = l_tot(y[:, 0], y[:, 1], ref)
    forward = best_time(lambda: net((V, t)), args.repeat)
    if args.optimizer == "newton":
        def call() -> object:
            return nh.refine(net, potential, nh.TIMES, method="newton", tol=args.tol)

        r = call()
        seconds = best_time(call, args.repeat)
    else:
        r = nh.refine(net, potential, nh.TIMES, steps=args.steps, lr=args.lr,
                      optimizer=args.optimizer, collocation=args.collocation,
                      parameters=args.parameters)
        seconds = r.seconds
    after = l_tot(r.q, r.p, ref)
    target = max(after, 1e-14)
    solve = best_time(lambda: nh.solve_classical(potential, nh.TIMES, tol=target),
                      args.repeat)
    sol = nh.solve_classical(potential, nh.TIMES, tol=target)
    return {"potential": label, "before": before, "forward": forward, "after": after,
            "refine": seconds, "res0": r.residual_before, "res1": r.residual_after,
            "classical": solve, "classical_err": l_tot(sol.q, sol.p, ref),
            "substeps": sol.substeps, "converged": r.converged,
            "from_zero": from_zero(potential, ref, args) if args.optimizer == "newton"
            else None}


def from_zero(potential, ref: tuple[np.ndarray, np.ndarray], args: argparse.Namespace
              ) -> str:
    """The same Newton collocation from the guess q ≡ 0: its L_tot, or why not."""
    if not callable(getattr(potential, "dV", None)):
        return "—"
    dV = potential.dV

    def d2V(q: np.ndarray) -> np.ndarray:
        return (dV(q + 1e-6) - dV(q - 1e-6)) / 2e-6

    sol = collocate(dV, d2V, lambda t: 0.0 * t, float(nh.TIMES[-1]), tol=args.tol)
    if not np.all(np.isfinite(sol.q)):
        return "diverged"
    q, p = sol(nh.TIMES)
    return f"{l_tot(q, p, ref):.1e}" + ("" if sol.converged else " (not converged)")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--networks", nargs="+", default=["deeponet-paper"],
                        help="shipped names or nh.train run directories (pointwise nets)")
    parser.add_argument("--optimizer", choices=["adam", "lbfgs", "newton"], default="adam",
                        help="newton: nh.refine(method='newton'), the trajectory refined")
    parser.add_argument("--tol", type=float, default=1e-10, help="newton's tolerance")
    parser.add_argument("--steps", type=int, default=500)
    parser.add_argument("--lr", type=float, default=1e-4)
    parser.add_argument("--collocation", type=int, default=200)
    parser.add_argument("--parameters", nargs="+", help="refine only these parameters "
                        "(name prefixes, e.g. branch.linears.3: DeepONet's last branch "
                        "layer); default all")
    parser.add_argument("--ood", type=int, default=4, help="OOD potentials (seed 0)")
    parser.add_argument("--repeat", type=int, default=5, help="timings: best of")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    potentials = list(nh.PHYSICAL_POTENTIALS.items())
    for i, pot in enumerate(ood_potentials(args.ood, 0) if args.ood else []):
        potentials.append((f"ood {i}: {getattr(pot, 'name', type(pot).__name__)}", pot))
    if args.optimizer == "newton":
        print(f"newton, tol {args.tol:g}, {args.threads} thread(s), CPU; times: best of "
              f"{args.repeat} (refine: network forward included)")
    else:
        print(f"{args.optimizer}, {args.steps} steps, lr {args.lr:g}, {args.collocation} "
              f"collocation times, parameters {args.parameters or 'all'}, {args.threads} "
              f"thread(s), CPU; times: best of {args.repeat}")
    print()
    print("| network | potential | L_tot before | after | refine ms | residual before → after"
          " | classical ms at that tol (RK4 substeps) | classical L_tot | network forward ms |"
          " worth it | converged | Newton from q ≡ 0 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.networks:
        label, net = network(name)
        for pot_name, pot in potentials:
            r = row(pot_name, pot, net, args)
            better = r["after"] < r["before"]
            worth = "yes" if better and r["refine"] < r["classical"] else (
                "no: slower than classical" if better else
                "no: network's answer kept" if r["after"] == r["before"] else "no: worse")
            print(f"| {label} | {r['potential']} | {r['before']:.2e} | {r['after']:.2e} | "
                  f"{r['refine'] * 1e3:.3g} | {r['res0']:.1e} → {r['res1']:.1e} | "
                  f"{r['classical'] * 1e3:.3g} ({r['substeps']}) | {r['classical_err']:.1e} | "
                  f"{r['forward'] * 1e3:.3g} | {worth} | {r['converged']} | "
                  f"{r['from_zero'] or '—'} |", flush=True)


if __name__ == "__main__":
    main()
