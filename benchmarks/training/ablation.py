"""The training ablation of issue 13: one row per change, scored on common sets.

Every run directory under ``--runs`` named ``NAME-sSEED`` is one seed of the change
NAME (``base`` is the baseline). Each network is scored, with the weights its
checkpoint holds, on

- the validation split of ``--val`` (the 2,000 held-out potentials of the standard
  set; runs trained on other files are scored there too, so every row is comparable),
- and on ``--test`` (the 4,000-potential test set), when given.

Datasets with starting states (``--states energy``) score networks that read them
(``initial_state=True``); score such runs in a folder of their own.

The table has, per change: the seeds, training minutes and epochs (mean over seeds),
training throughput in potentials per second, the validation mean L_tot (mean over
seeds, with the seeds' range), the test mean, and the ratio of the validation mean to
the baseline's. Choose on the validation column; the test column is for the record.

Run it with::

    python benchmarks/training/ablation.py --runs runs/abl --val paper-standard.h5 \\
        --test paper-test.h5 [--json ablation.json]
"""

import argparse
import collections
import json
import re
from pathlib import Path

import numpy as np

from nh_operators.data import load_dataset
from nh_operators.evaluation import loss_per_sample
from nh_operators.models import batched_forward
from nh_operators.training import load_checkpoint, load_model, read_history


def scores(net, V, t, q, p, batch_size=500):
    out = np.concatenate([o.cpu().numpy().astype(np.float64)
                          for _, o in batched_forward(net, V, t[:, None], batch_size)])
    return loss_per_sample(out[..., 0], out[..., 1], q, p)["L_tot"]


def split(path, part):
    ds = load_dataset(path)
    V = ds.branch_input()  # with starting states: the sensors, then q0 and p0
    if part == "all":
        return V, ds.t, ds.q, ds.p
    _, val = ds.split_indices()
    return V[val], ds.t, ds.q[val], ds.p[val]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", required=True, help="folder of NAME-sSEED run directories")
    ap.add_argument("--val", required=True, help="dataset whose validation split scores")
    ap.add_argument("--test", help="test set .h5 (scored whole)")
    ap.add_argument("--baseline", default="base", help="the change the ratios refer to")
    ap.add_argument("--json", help="also write the per-run numbers here")
    ap.add_argument("--device", default="cpu", help="where the networks run (cpu, cuda)")
    args = ap.parse_args()

    sets = {"val": split(args.val, "val")}
    val_rows, val_checksum = _rows_and_checksum(args.val)
    if args.test:
        sets["test"] = split(args.test, "all")
    runs = collections.defaultdict(list)
    for run in sorted(Path(args.runs).iterdir()):
        match = re.fullmatch(r"(.+)-s(\d+)", run.name)
        if not (match and (run / "checkpoint.pt").exists()):
            continue
        net, cfg = load_model(run, device=args.device)
        hist = read_history(run)
        state = load_checkpoint(run)
        n_train = state.get("train_rows")
        if n_train is None:  # checkpoints before train_rows: known if it is --val's file
            n_train = (round(cfg["train_fraction"] * val_rows)
                       if state["data_checksum"] == val_checksum else np.nan)
        record = {"seed": int(match[2]), "epochs": int(hist["epoch"][-1]),
                  "minutes": float(hist["seconds"][-1]) / 60,
                  "own_val": float(hist["val_loss"][-1])}
        record["per_s"] = record["epochs"] * n_train / (60 * record["minutes"])
        for name, (V, t, q, p) in sets.items():
            record[name] = float(np.mean(scores(net, V, t, q, p)))
        runs[match[1]].append(record)
    base = np.mean([r["val"] for r in runs.get(args.baseline, [])] or [np.nan])
    head = "| change | seeds | minutes | epochs | potentials/s | validation mean (range) " \
           "| test mean | val ratio to base |"
    print(head)
    print("|" + "---|" * 8)
    order = sorted(runs, key=lambda k: (k != args.baseline, np.mean([r["val"] for r in runs[k]])))
    for name in order:
        rs = runs[name]
        val = [r["val"] for r in rs]
        test = np.mean([r.get("test", np.nan) for r in rs])
        print(f"| {name} | {len(rs)} | {np.mean([r['minutes'] for r in rs]):.1f} | "
              f"{np.mean([r['epochs'] for r in rs]):.1f} | "
              f"{np.mean([r['per_s'] for r in rs]):.0f} | {np.mean(val):.3e} "
              f"({min(val):.2e}–{max(val):.2e}) | {test:.3e} | {np.mean(val) / base:.2f} |")
    if args.json:
        Path(args.json).write_text(json.dumps(runs, indent=1) + "\n")


def _rows_and_checksum(path):
    from nh_operators.data import dataset_attrs

    attrs = dataset_attrs(path)
    return int(attrs["size"]), attrs["checksum"]


if __name__ == "__main__":
    main()
