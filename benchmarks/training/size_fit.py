"""What size buys (issue 25): fit a ladder's error against its parameter count.

Reads the output folder of ``ladder.py`` (``plan.json``, ``ablation.json`` and each run's
``history.csv``) and prints, per group (one architecture, variant and recipe):

1. **Equal epochs** (the ladder's design): per size, the parameters, epochs, minutes,
   validation mean over the seeds (with their range) and test mean.
2. **Equal wall clock**: every run's validation loss (its own history, the weights it
   checkpoints) at the last epoch finished within ``--minutes``; a run whose schedule
   ended earlier is marked.
3. **The fit** log10(val) = a + b·log10(params) by least squares over every run of the
   group (all seeds), with b's standard error, and the spread of b over every choice of
   one seed per size. Then, **labelled as extrapolation**, the fitted validation loss at
   the paper's size of the same network (the ``paper`` preset with the run's variant and
   options) with a 95 % interval of the fitted line (Student t, n − 2 degrees of
   freedom: it counts the seeds' noise, not whether a power law holds that far), and
   the parameter count at which the fit reaches the validation loss of ``--cross``
   (TraONet by default).

The fit holds the epochs fixed: it says what size buys at the ladder's epochs, not
after the paper's 250.

Run it with::

    python benchmarks/training/size_fit.py --ladder ladder/cpu20 --minutes 20
"""

import argparse
import itertools
import json
import math
import sys
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parent))
from ladder import run_params  # noqa: E402

from nh_operators.training import read_history  # noqa: E402

SIZE_KEYS = ("hidden_size=", "d_model=", "dim_feedforward=")


def paper_args(args):
    """A run's train arguments at the paper's size: preset ``paper``, no size options."""
    out, skip = [], False
    for i, a in enumerate(args):
        if skip:
            skip = False
            continue
        if a == "--arch" and args[i + 1].startswith(SIZE_KEYS):
            skip = True
            continue
        out.append("paper" if i > 0 and args[i - 1] == "--preset" else a)
    return out


def line_fit(x, y):
    """Least squares y = a + b x: (a, b, se of b, residual s, mean x, Sxx)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    xm, sxx = x.mean(), float(np.sum((x - x.mean()) ** 2))
    b = float(np.sum((x - xm) * (y - y.mean())) / sxx)
    a = float(y.mean() - b * xm)
    dof = len(x) - 2
    s = math.sqrt(float(np.sum((y - a - b * x) ** 2)) / dof) if dof > 0 else math.nan
    return a, b, s / math.sqrt(sxx), s, xm, sxx


def half_width(x0, n, s, xm, sxx):
    """Half width of the fitted line's 95 % interval at x0 (n points, Student t)."""
    return stats.t.ppf(0.975, n - 2) * s * math.sqrt(1 / n + (x0 - xm) ** 2 / sxx)


def at_minutes(hist, minutes):
    """(validation loss, epoch) at the last epoch finished within ``minutes``."""
    done = [i for i, sec in enumerate(hist["seconds"]) if sec <= 60 * minutes]
    if not done:
        return math.nan, 0
    return float(hist["val_loss"][done[-1]]), int(hist["epoch"][done[-1]])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ladder", required=True, help="the --out folder of ladder.py")
    ap.add_argument("--minutes", type=float, required=True,
                    help="the wall clock of the equal-time table")
    ap.add_argument("--cross", default="traonet",
                    help="architecture whose validation loss the fits are crossed with")
    ap.add_argument("--at", type=int, nargs="*", default=[], metavar="PARAMS",
                    help="also print every fit's value (95 %% interval) at these parameter counts")
    args = ap.parse_args()
    folder = Path(args.ladder)
    for need in ("plan.json", "ablation.json"):
        if not (folder / need).exists():
            sys.exit(f"{folder / need} is missing: run ladder.py --out {folder} first")
    plan = json.loads((folder / "plan.json").read_text())
    scores = json.loads((folder / "ablation.json").read_text())
    groups = {}
    for run in plan:
        rec = next((r for r in scores.get(run["name"], []) if r["seed"] == run["seed"]), None)
        if rec is None:
            continue
        run.update(params=run_params(run), paper_params=run_params(
            dict(run, args=paper_args(run["args"]))), **rec)
        run["hist"] = read_history(Path(run["out"]) / "history.csv")
        groups.setdefault(run["group"], []).append(run)

    print("| group | size | parameters | seeds | epochs | minutes | validation mean (range) "
          "| test mean |")
    print("|" + "---|" * 8)
    for group, runs in groups.items():
        for name in dict.fromkeys(r["name"] for r in runs):
            rs = [r for r in runs if r["name"] == name]
            val = [r["val"] for r in rs]
            print(f"| {group} | {name.rsplit('-', 1)[1]} | {rs[0]['params']:,} | {len(rs)} | "
                  f"{np.mean([r['epochs'] for r in rs]):.0f} | "
                  f"{np.mean([r['minutes'] for r in rs]):.1f} | {np.mean(val):.3e} "
                  f"({min(val):.2e}–{max(val):.2e}) | "
                  f"{np.mean([r.get('test', math.nan) for r in rs]):.3e} |")

    print(f"\nAt {args.minutes:g} minutes of wall clock (own history; * = its schedule "
          "ended earlier):\n")
    print("| run | seed | epoch | validation |")
    print("|---|---|---|---|")
    for runs in groups.values():
        for r in runs:
            val, epoch = at_minutes(r["hist"], args.minutes)
            ended = "*" if r["hist"]["seconds"][-1] < 60 * args.minutes else ""
            print(f"| {r['name']} | {r['seed']} | {epoch}{ended} | {val:.3e} |")

    def level(group):  # log10 of the --cross network's validation mean, same combination
        tag = group.split("-")[1]
        vals = [r["val"] for r in groups.get(f"{args.cross}-{tag}", [])]
        return math.log10(np.mean(vals)) if vals else math.nan

    print("\nThe fit log10(val) = a + b log10(params), per group; EXTRAPOLATION beyond "
          "the ladder's sizes:\n")
    print(f"| group | runs | slope b ± se | b over one seed per size | fitted val at the "
          f"paper's size (95 % interval) | paper's parameters | {args.cross} of the same "
          f"combination | the fit reaches it at |")
    print("|" + "---|" * 8)
    fits = {}
    for group, runs in groups.items():
        sizes = sorted({r["params"] for r in runs})
        if len(sizes) < 3 or group.startswith(args.cross + "-"):
            continue
        x = [math.log10(r["params"]) for r in runs]
        y = [math.log10(r["val"]) for r in runs]
        a, b, se, s, xm, sxx = line_fit(x, y)
        by_size = [[math.log10(r["val"]) for r in runs if r["params"] == n] for n in sizes]
        slopes = [line_fit([math.log10(n) for n in sizes], pick)[1]
                  for pick in itertools.product(*by_size)]
        fits[group] = (a, b, (len(x), s, xm, sxx))
        x0 = math.log10(runs[0]["paper_params"])
        half, y0 = half_width(x0, len(x), s, xm, sxx), a + b * x0
        cross = level(group)
        reach = 10 ** ((cross - a) / b) if b < 0 and math.isfinite(cross) else math.nan
        print(f"| {group} | {len(runs)} | {b:.2f} ± {se:.2f} | {min(slopes):.2f} to "
              f"{max(slopes):.2f} | {10 ** y0:.1e} ({10 ** (y0 - half):.1e}–"
              f"{10 ** (y0 + half):.1e}) | {runs[0]['paper_params']:,} | {10 ** cross:.2e} | "
              + (f"{reach:,.0f} parameters |" if math.isfinite(reach)
                 else "– (no fall with size) |" if b >= 0 else "– (no such run) |"))

    for n in args.at:
        print(f"\nEvery fit at {n:,} parameters (95 % interval of the line):\n")
        for group, (a, b, spread) in fits.items():
            y, half = a + b * math.log10(n), half_width(math.log10(n), *spread)
            print(f"- {group}: {10 ** y:.2e} ({10 ** (y - half):.2e}–{10 ** (y + half):.2e})")


if __name__ == "__main__":
    main()
