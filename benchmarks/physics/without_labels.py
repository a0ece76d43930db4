"""What does training on Hamilton's equations buy, at equal CPU minutes? (issue 43 §2)

For each network (DeepONet; TraONet with ``query_coupled=False``) and seed, every mode
trains for the same wall-clock budget (``--minutes``) on the same small
``paper-standard``-distribution dataset, then scores on small ``paper-test`` and
``alg1-test`` sets (the first ``--test-size`` potentials of each preset's stream):

* ``data``: today's training, all labels (``physics=None``);
* ``physics``: the residual only, not one label (``physics={}``);
* ``energy``: the residual and the energy drift (weight ``--energy``, default 1), no label
  (``physics={"energy": 1}``): the drift term is what keeps the residual from settling on
  the trivial answer "roll to the bottom of the well and stay", which has a small
  residual and an energy far below V0;
* ``hybrid``: 10 % of the labels plus the residual and the energy term
  (``label_fraction=0.1``);
* ``finetune``: labels for half the minutes (``physics={"residual": 0,
  "label_fraction": 1}``: the labels through the same hard starting state), then the
  residual and energy terms for the other half (that checkpoint, its config switched
  to ``physics={"energy": 1}``, resumed: the optimiser state carries on);
* ``causal`` (only when asked for with ``--modes``): the residual and energy terms with
  the causal weighting ε = ``--causal`` (default 10);
* ``curriculum`` (only when asked for): the residual and energy terms on a horizon that
  widens from 0.25 to 2 over ``--curriculum`` iterations; ``causal-curriculum``: both.
* ``labels-10`` and ``hybrid-light`` (only when asked for): the same 10 % of the labels
  alone (``residual=0``), and beside a light residual (weight ``--light``, default 0.01,
  no energy term): whether a residual that does not drown the labels adds anything.
* ``integral``, ``integral-energy`` and ``hybrid-integral`` (only when asked for): the
  residual in integral (Picard) form, q − q0 − ∫p and p − p0 − ∫F(q) by the trapezoid
  rule (``physics={"form": "integral"}``): alone, with the energy term, and beside the
  same 10 % of the labels (weight 1 each). No derivative of the network is taken.
* ``window`` (only when asked for): time-marching. A DeepONet that reads a starting state
  learns, from the residual and energy terms on [0, ``--window``] only, the flow over one
  short window, on ``paper-states-standard`` potentials from random states; its
  trajectory on [0, 2] is the windows composed, each from the last one's end
  (``windows.py`` beside this script; no residual column, the windows' joints have none).

Every run keeps its checkpoint in ``--out/runs/MODEL-MODE-sSEED``: an interrupted
benchmark resumes (``nh.train(..., resume=True, max_minutes=...)``) and finished runs
are not trained again (their scores are cached as JSON next to them).

Reported per row (mean over the seeds of each seed's statistic): mean and median
L_tot, the mean squared energy drift (p²/2 + V(q) − V0)² and the mean squared residual of
dq/dt = p, dp/dt = −V'(q) (V from the sensors' spline, derivatives by autograd in
float64, on the 100 grid times), and the epochs each seed reached.

The learning rate is constant and the same for every mode (``--lr``, default 1e-3): the
schedules are defined in epochs, and at equal minutes the modes run very different
numbers of epochs. (At DeepONet's recipe value, 7.3e-3, the residual modes spiked and
diverged within a minute.)

Run it (about minutes × modes × models × seeds, one thread; docs/without_labels.md
quotes this one, 1 minute per run, about 25 minutes in all)::

    OMP_NUM_THREADS=1 python benchmarks/physics/without_labels.py --minutes 1 \\
        --seeds 0 1 --models deeponet traonet --modes energy data physics hybrid finetune \\
        --out runs/physics
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import torch

import nh_operators as nh
from nh_operators.data import SensorSpline, load_dataset, preset_kwargs, time_derivative
from nh_operators.models import batched_forward, cast_network
from nh_operators.training import load_checkpoint, load_model, save_checkpoint

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from windows import scores as window_scores  # noqa: E402  (a sibling script)
from windows import window_physics  # noqa: E402

MODES = ("data", "physics", "energy", "hybrid", "finetune", "causal", "curriculum",
         "causal-curriculum", "labels-10", "hybrid-light", "integral", "integral-energy",
         "hybrid-integral", "window")
ARCH = {"deeponet": {}, "traonet": {"query_coupled": False},
        "mambonet": {"query_coupled": False}, "varonet": {"query_coupled": False}}


def datasets(folder: Path, train_size: int, test_size: int,
             states: bool = False) -> dict[str, Path]:
    """Generate (once) the training set and the two test sets (with ``states``, also a
    training set from random states); their paths."""
    folder.mkdir(parents=True, exist_ok=True)
    plan = {"train": (train_size, 8407, preset_kwargs("paper-standard")),
            "paper-test": (test_size, 42, preset_kwargs("paper-test")),
            "alg1-test": (test_size, 42, preset_kwargs("alg1-test"))}
    if states:
        plan["train-states"] = (train_size, 8407, preset_kwargs("paper-states-standard"))
    paths = {}
    for name, (size, seed, kwargs) in plan.items():
        paths[name] = folder / f"{name}-{size}.h5"
        if not paths[name].exists():
            nh.generate_dataset(size, seed, str(paths[name]), progress=False, **kwargs)
    return paths


def physics_of(mode: str, args: argparse.Namespace) -> dict | None:
    """The ``TrainConfig.physics`` of a mode (for finetune: of its second half)."""
    energy = {"energy": args.energy}
    return {"data": None, "physics": {}, "energy": energy,
            "hybrid": {"label_fraction": 0.1, **energy}, "finetune": energy,
            "causal": {"causal": args.causal, **energy},
            "curriculum": {"curriculum": args.curriculum, **energy},
            "causal-curriculum": {"causal": args.causal, "curriculum": args.curriculum,
                                  **energy},
            # the same 10 % of the labels alone, and with a light residual beside them
            "labels-10": {"label_fraction": 0.1, "residual": 0.0},
            "hybrid-light": {"label_fraction": 0.1, "residual": args.light},
            # the residual in integral (Picard) form: no time derivative of the network
            "integral": {"form": "integral"},
            "integral-energy": {"form": "integral", **energy},
            "hybrid-integral": {"form": "integral", "label_fraction": 0.1},
            "window": window_physics(args.window, args.energy)}[mode]


def config(model: str, mode: str, seed: int, args: argparse.Namespace,
           physics: dict | None) -> nh.TrainConfig:
    arch = {**ARCH[model], **({"initial_state": True} if mode == "window" else {})}
    return nh.TrainConfig(model, preset="cpu", arch=arch, epochs=args.epochs,
                          seed=seed, batch_size=args.batch_size, scheduler="constant",
                          lr=args.lr,
                          device=args.device, physics=physics)


def train_run(model: str, mode: str, seed: int, train_path: Path, run: Path,
              args: argparse.Namespace) -> None:
    """Train (or resume) one run to its minutes."""
    if mode != "finetune":
        cfg = config(model, mode, seed, args, physics_of(mode, args))
        nh.train(cfg, str(train_path), run, resume=True, progress=False,
                 max_minutes=args.minutes)
        return
    first = run.with_name(run.name + "-labels")
    # labels only, but with the residual modes' output transform (q = t·y), so that the
    # weights mean the same function in the second half
    labels = {"residual": 0.0, "label_fraction": 1.0}
    nh.train(config(model, "data", seed, args, labels), str(train_path), first,
             resume=True, progress=False, max_minutes=args.minutes / 2)
    second = config(model, mode, seed, args, physics_of(mode, args))
    if not (run / "checkpoint.pt").exists():  # the switch: same weights, new loss
        state = load_checkpoint(first)
        state["config"] = {**state["config"], "physics": second.resolved()["physics"]}
        run.mkdir(parents=True, exist_ok=True)
        save_checkpoint(run, {k: v for k, v in state.items() if k != "format"})
        shutil.copy(first / "history.csv", run / "history.csv")
    nh.train(second, str(train_path), run, resume=True, progress=False,
             max_minutes=args.minutes)


def score(net: torch.nn.Module, path: Path) -> dict[str, float]:
    """Mean and median L_tot, energy drift and residual of a network on a test set."""
    data = load_dataset(str(path))
    V, q, p = data.V, data.q, data.p
    y = np.concatenate([o.double().numpy()
                        for _, o in batched_forward(net, V, data.t[:, None], 500)])
    loss = 0.5 * (np.mean((y[..., 0] - q) ** 2, axis=1) + np.mean((y[..., 1] - p) ** 2,
                                                                   axis=1))
    net64 = cast_network(net, torch.float64).eval()
    spline = SensorSpline(data.x)
    drift, residual = [], []
    for start in range(0, len(V), 100):
        Vb = torch.tensor(V[start:start + 100], dtype=torch.float64)
        t = torch.tensor(data.t[:, None], dtype=torch.float64, requires_grad=True)
        out = net64((Vb, t))
        dy = time_derivative(out, t)
        value, slope = spline(Vb, out[..., 0])
        energy = 0.5 * out[..., 1] ** 2 + value - Vb[:, :1]
        res = 0.5 * ((dy[..., 0] - out[..., 1]) ** 2 + (dy[..., 1] + slope) ** 2)
        drift.append(torch.mean(energy ** 2, dim=1).detach().numpy())
        residual.append(torch.mean(res, dim=1).detach().numpy())
    return {"mean": float(loss.mean()), "median": float(np.median(loss)),
            "drift": float(np.concatenate(drift).mean()),
            "residual": float(np.concatenate(residual).mean())}


def one(model: str, mode: str, seed: int, paths: dict[str, Path],
        args: argparse.Namespace) -> dict:
    run = args.out / "runs" / f"{model}-{mode}-s{seed}"
    cached = run / "scores.json"
    if cached.exists():
        return json.loads(cached.read_text())
    start = time.perf_counter()
    train_run(model, mode, seed, paths["train-states" if mode == "window" else "train"],
              run, args)
    net, _ = load_model(run)
    history = (run / "history.csv").read_text().strip().splitlines()
    last = dict(zip(history[0].split(","), history[-1].split(","), strict=True))
    result = {"model": model, "mode": mode, "seed": seed, "epochs": int(last["epoch"]),
              "minutes": float(last["seconds"]) / 60, "wall": time.perf_counter() - start}
    for name in ("paper-test", "alg1-test"):
        result[name] = (window_scores(net, str(paths[name]), args.window)
                        if mode == "window" else score(net, paths[name]))
    cached.write_text(json.dumps(result, indent=1))
    return result


def table(results: list[dict], args: argparse.Namespace) -> str:
    lines = [(f"{args.minutes:g} min per run (finetune: {args.minutes / 2:g} + "
              f"{args.minutes / 2:g}), {args.threads} thread(s), {args.device}, seeds "
              f"{' '.join(map(str, args.seeds))}, train {args.train_size} paper-standard "
              f"potentials (80 % train), tests: first {args.test_size} of paper-test and "
              f"alg1-test; constant lr {args.lr:g}; values are means over seeds"
              + (f"; window: {args.train_size} paper-states-standard potentials from "
                 f"random states, window {args.window:g}" if "window" in args.modes
                 else "")), "",
             ("| model | mode | epochs (per seed) | paper-test mean L_tot | median | "
              "alg1-test mean L_tot | median | energy drift (paper) | residual (paper) |"),
             "|---|---|---|---|---|---|---|---|---|"]
    for model in args.models:
        for mode in args.modes:
            rows = [r for r in results if r["model"] == model and r["mode"] == mode]
            if not rows:
                continue

            def avg(test: str, key: str, rows: list[dict] = rows) -> float:
                return float(np.mean([r[test][key] for r in rows]))

            epochs = "/".join(str(r["epochs"]) for r in rows)
            lines.append(f"| {model} | {mode} | {epochs} | {avg('paper-test', 'mean'):.2e} | "
                         f"{avg('paper-test', 'median'):.2e} | {avg('alg1-test', 'mean'):.2e} |"
                         f" {avg('alg1-test', 'median'):.2e} | {avg('paper-test', 'drift'):.2e}"
                         f" | {avg('paper-test', 'residual'):.2e} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, default=2.0, help="wall minutes per run")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--models", nargs="+", default=["deeponet", "traonet"],
                        choices=sorted(ARCH))
    parser.add_argument("--modes", nargs="+", default=list(MODES[:7]), choices=MODES)
    parser.add_argument("--out", type=Path, default=Path("runs/physics"))
    parser.add_argument("--train-size", type=int, default=2000)
    parser.add_argument("--test-size", type=int, default=300)
    parser.add_argument("--epochs", type=int, default=10_000,
                        help="cap on epochs (the minutes stop a run first)")
    parser.add_argument("--batch-size", type=int, default=100)
    parser.add_argument("--lr", type=float, default=1e-3,
                        help="constant learning rate of every mode (default 1e-3: the "
                        "DeepONet recipe's 7.3e-3 made the residual modes diverge)")
    parser.add_argument("--causal", type=float, default=10.0, help="ε of the causal mode")
    parser.add_argument("--light", type=float, default=0.01,
                        help="the residual's weight in hybrid-light (labels: 1)")
    parser.add_argument("--energy", type=float, default=1.0,
                        help="weight of the energy term in every residual mode but physics")
    parser.add_argument("--curriculum", type=int, default=20_000,
                        help="iterations of the curriculum modes' widening horizon")
    parser.add_argument("--window", type=float, default=0.25,
                        help="the window mode's window (its trajectory: 2 / window of them)")
    parser.add_argument("--device", default="cpu", help="cpu (default) or cuda")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    paths = datasets(args.out / "data", args.train_size, args.test_size,
                     states="window" in args.modes)
    results = []
    for seed in args.seeds:
        for model in args.models:
            for mode in args.modes:
                results.append(one(model, mode, seed, paths, args))
                r = results[-1]
                print(f"# {model} {mode} seed {seed}: {r['epochs']} epochs, paper-test "
                      f"{r['paper-test']['mean']:.2e}, alg1-test {r['alg1-test']['mean']:.2e}",
                      flush=True)
    text = table(results, args)
    (args.out / "table.md").write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
