"""What size buys (issue 25): train a ladder of sizes side by side, sized to a time budget.

Each run of the plan is ``nh-operators train`` in its own process (one thread each),
all of them at once (``--jobs`` at a time). First every run trains one epoch (the
probe, under the same contention as the real runs); then each *group* (one
architecture, variant and recipe) gets the number of epochs that its slowest member
fits into ``--minutes``, so that the sizes of a group compare at equal epochs, each
with a finished schedule. The schedule is compressed to those epochs: upper bound
1.2 × epochs, the paper's 300 / 250. ``--max-minutes`` guards each run; a run it
cuts is marked in the table. The runs are then scored by ``ablation.py`` (validation
split of ``--data``, and ``--test``) on ``--device``.

Plans:

- ``gpu``: VaRONet H = 128, 256, 512 (4 layers, latent 30: the paper's at H = 512)
  and MambONet d = 32, 64, 128 (4 + 4 layers, feed-forward 8d: the paper's at
  d = 128), each as **reference** (the authors' network and recipe; seeds 0 and 1)
  and **ours** (our network and recipe as shipped; seed 0); TraONet at the paper's
  size, reference and ours, seed 0.
- ``cpu``: the same shapes at the ``cpu`` preset's depth (2 + 2 layers) and H = 32,
  64, 128 / d = 16, 32, 64, and TraONet at the ``cpu`` size, seed 0 (``--seeds 0 1``
  for two; the 2-core CPU runs two at a time).

Run it with::

    python benchmarks/training/ladder.py --plan gpu --data paper-standard.h5 \\
        --test paper-test.h5 --out ladder-gpu --minutes 6 --device cuda --jobs 20

``--params`` prints the networks' parameter counts instead. It writes ``OUT/plan.json`` (epochs per run, probe seconds), ``OUT/runs/NAME-sSEED``
(run directories), ``OUT/logs/`` and ``OUT/ablation.json``, and prints the table.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

from nh_operators.training import read_history

HERE = Path(__file__).resolve().parent

#: Our recipe as shipped (docs/recipe.md): batch 50, the paper's lr / sqrt(2), EMA.
OURS = {
    "varonet": ["--batch-size", "50", "--ema", "0.999", "--lr", "0.0006132",
                "--arch", "encoder_cell=True"],
    "mambonet": ["--batch-size", "50", "--ema", "0.999", "--lr", "0.0006925",
                 "--arch", "activation=gelu", "--arch", "norm_first=True",
                 "--arch", "query_attention=False"],
    "traonet": ["--batch-size", "50", "--ema", "0.999", "--lr", "0.0010356",
                "--arch", "activation=gelu", "--arch", "norm_first=True",
                "--arch", "query_attention=False"],
}


def _size_args(model, size, plan):
    if model == "varonet":
        return ["--arch", f"hidden_size={size}"]
    if model == "mambonet":
        return ["--arch", f"d_model={size}",
                "--arch", f"dim_feedforward={(8 if plan == 'gpu' else 4) * size}"]
    return []


def plan_runs(plan, seeds=None, sizes=None, combos=("reference", "ours")):
    """The runs of a plan: dicts with name, seed, group and the train arguments;
    ``seeds`` replaces the plan's seeds for every combination, ``sizes`` (a dict
    architecture -> sizes) the plan's sizes of those architectures, ``combos`` keeps
    only these combinations."""
    preset = "paper" if plan == "gpu" else "cpu"
    sizes = dict({"gpu": {"varonet": (128, 256, 512), "mambonet": (32, 64, 128),
                          "traonet": (64,)},
                  "cpu": {"varonet": (32, 64, 128), "mambonet": (16, 32, 64),
                          "traonet": (32,)}}[plan], **(sizes or {}))
    plan_seeds = {"reference": (0, 1) if plan == "gpu" else (0,), "ours": (0,)}
    if seeds is not None:
        plan_seeds = {"reference": tuple(seeds), "ours": tuple(seeds)}
    runs = []
    for model, model_sizes in sizes.items():
        for combo in combos:
            for size in model_sizes:
                for seed in plan_seeds[combo] if model != "traonet" else (0,):
                    tag = "ref" if combo == "reference" else "ours"
                    args = ["--model", model, "--preset", preset, "--variant", combo,
                            "--recipe", combo, "--seed", str(seed),
                            *_size_args(model, size, plan)]
                    if combo == "ours":
                        args += OURS[model]
                    runs.append({"name": f"{model}-{tag}-{size}", "seed": seed,
                                 "group": f"{model}-{tag}", "args": args})
    return runs


def run_params(run):
    """The parameter count of a run's network (built from its train arguments)."""
    from nh_operators.models import build_model

    args = run["args"]
    model, preset, variant = (args[args.index(flag) + 1]
                              for flag in ("--model", "--preset", "--variant"))
    arch = dict(a.split("=") for a, flag in zip(args[1:], args) if flag == "--arch")
    arch = {k: int(v) if v.isdigit() else {"True": True, "False": False}.get(v, v)
            for k, v in arch.items()}
    net = build_model(model, preset=preset, variant=variant, **arch)
    return sum(p.numel() for p in net.parameters())


def print_params(runs):
    """Parameter counts of the plan's networks (one line per name)."""
    seen = set()
    for run in runs:
        if run["name"] not in seen:
            seen.add(run["name"])
            print(f"{run['name']}: {run_params(run):,} parameters")


def launch(runs, out, extra, jobs, env):
    """Run ``nh-operators train`` for every run, ``jobs`` at a time; wait for all."""
    pending, active = list(runs), []
    while pending or active:
        while pending and len(active) < jobs:
            run = pending.pop(0)
            log = open(out / "logs" / f"{run['dir']}.log", "w")
            cmd = [sys.executable, "-m", "nh_operators.cli.main", "train", "--quiet",
                   "--out", str(run["out"]), *run["args"], *extra(run)]
            active.append((subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                                            env=env), log, run))
        time.sleep(1.0)
        for proc, log, run in list(active):
            if proc.poll() is not None:
                log.close()
                run["returncode"] = proc.returncode
                active.remove((proc, log, run))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--plan", choices=("gpu", "cpu"), default="gpu")
    ap.add_argument("--data", required=True, help="training set (its validation split scores)")
    ap.add_argument("--test", help="test set .h5 for the table")
    ap.add_argument("--out", required=True)
    ap.add_argument("--minutes", type=float, default=6.0, help="training budget per run")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--jobs", type=int, default=2, help="runs at once (one thread each)")
    ap.add_argument("--only", nargs="*", help="run only these names (NAME or NAME-sSEED)")
    ap.add_argument("--seeds", type=int, nargs="+",
                    help="seeds of every run (default: the plan's, see above)")
    ap.add_argument("--sizes", nargs="+", default=[], metavar="MODEL=S1,S2,...",
                    help="replace the plan's sizes of an architecture, e.g. mambonet=8,16,32")
    ap.add_argument("--combos", nargs="+", choices=("reference", "ours"),
                    default=("reference", "ours"), help="combinations to run (default both)")
    ap.add_argument("--params", action="store_true",
                    help="print each run's parameter count and stop (nothing is trained)")
    args = ap.parse_args()
    sizes = {}
    for item in args.sizes:
        model, _, values = item.partition("=")
        try:
            sizes[model] = tuple(int(v) for v in values.split(","))
        except ValueError:
            ap.error(f"--sizes {item!r}: expected MODEL=S1,S2,... with integer sizes")
        if model not in OURS:
            ap.error(f"--sizes {item!r}: unknown architecture {model!r} "
                     f"(one of {', '.join(OURS)})")
    plan = dict(seeds=args.seeds, sizes=sizes, combos=tuple(args.combos))
    if args.params:
        return print_params(plan_runs(args.plan, **plan))

    out = Path(args.out)
    (out / "logs").mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", NUMBA_NUM_THREADS="1")
    runs = plan_runs(args.plan, **plan)
    if args.only:
        runs = [r for r in runs if r["name"] in args.only
                or f"{r['name']}-s{r['seed']}" in args.only]
    common = ["--data", args.data, "--device", args.device]
    for run in runs:
        run["dir"] = f"{run['name']}-s{run['seed']}"
        run["args"] += common

    for run in runs:
        run["out"] = out / "probe" / run["dir"]
    t0 = time.time()
    launch(runs, out, lambda run: ["--epochs", "1"], args.jobs, env)
    for run in runs:
        hist = run["out"] / "history.csv"
        run["probe_s"] = (float(read_history(hist)["seconds"][-1])
                          if run["returncode"] == 0 and hist.exists() else math.nan)
    print(f"probe: {time.time() - t0:.0f} s", flush=True)
    budget = 60 * args.minutes
    for group in {r["group"] for r in runs}:
        members = [r for r in runs if r["group"] == group]
        slowest = max(r["probe_s"] for r in members)
        epochs = max(2, int(0.9 * budget / slowest)) if math.isfinite(slowest) else 0
        for r in members:
            r["epochs"], r["upper_bound"] = epochs, math.ceil(1.2 * epochs)
    runs = [r for r in runs if r["epochs"] > 0]
    for run in runs:
        run["out"] = out / "runs" / run["dir"]
    t0 = time.time()
    launch(runs, out, lambda r: ["--epochs", str(r["epochs"]), "--upper-bound",
                                 str(r["upper_bound"]), "--max-minutes",
                                 str(args.minutes * 1.1)], args.jobs, env)
    print(f"training: {time.time() - t0:.0f} s", flush=True)
    for run in runs:
        hist = run["out"] / "history.csv"
        done = int(read_history(hist)["epoch"][-1]) if hist.exists() else 0
        run["epochs_run"], run["out"] = done, str(run["out"])
    tmp = out / "plan.json.tmp"
    tmp.write_text(json.dumps(runs, indent=1, default=str) + "\n")
    tmp.replace(out / "plan.json")
    for r in runs:
        cut = " (cut by --max-minutes)" if r["epochs_run"] < r["epochs"] else ""
        print(f"{r['dir']}: probe {r['probe_s']:.1f} s/epoch, {r['epochs_run']} of "
              f"{r['epochs']} epochs{cut}, exit {r['returncode']}")
    score = [sys.executable, str(HERE / "ablation.py"), "--runs", str(out / "runs"),
             "--val", args.data, "--json", str(out / "ablation.json"),
             "--device", args.device, "--baseline", runs[0]["name"]]
    subprocess.run(score + (["--test", args.test] if args.test else []), check=True)


if __name__ == "__main__":
    main()
