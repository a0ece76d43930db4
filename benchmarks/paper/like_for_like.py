"""The paper's test-set and physical-potential tables, like for like: our networks and
baselines scored on the distribution the paper's tables came from, next to its numbers.

Reads the ``report.json`` of ``nh-operators evaluate`` on ``paper-test.h5`` (the last
4,000 of the reference code's test draw, our exact labels) with the networks trained on
``paper-standard.h5`` (the paper's 10k data budget). Prints, in the paper's layout:

- mean, std, median and IQR of L_tot per method, with the paper's four numbers for the
  same method trained on its standard (10k) data, and the ratio of the means;
- the five physical potentials, with the paper's values (its models trained on the
  extended, 100k data: the only physical table it prints);
- for each network, the run's epochs, minutes and device, read from its run directory.

The paper's "RK4" row came from its code's RK4 (a first-order step, PCHIP force);
``paper_rk4`` is the same information (1 step per interval, PCHIP force of the sensors)
with a correct RK4 step. The correct RK4 and symplectic baselines on the same 100 sensors have no
paper column.

Run it with::

    nh-operators evaluate --test paper-test.h5 --run final/traonet-paper ... --out eval/paper
    python benchmarks/paper/like_for_like.py --report eval/paper/report.json
"""

import argparse
import json
import math
from pathlib import Path

#: The paper's test table for models trained on its standard dataset (10,000
#: potentials): mean, std, median, IQR of L_tot. "paper_rk4" is its RK4 row.
PAPER_10K = {
    "paper_rk4": (5.2852e-5, 1.0586e-4, 1.4802e-5, 6.0370e-5),
    "deeponet": (5.2533e-2, 4.4131e-2, 4.2962e-2, 6.2856e-2),
    "traonet": (1.6787e-4, 4.6630e-4, 6.9309e-5, 1.3676e-4),
    "varonet": (5.2175e-5, 3.3825e-4, 1.3215e-5, 2.6575e-5),
    "mambonet": (3.8228e-5, 3.2109e-4, 1.1698e-5, 1.9854e-5),
}
#: The same for its extended dataset (100,000 potentials).
PAPER_100K = {
    "deeponet": (4.4341e-2, 4.3616e-2, 3.4747e-2, 5.1906e-2),
    "traonet": (9.3756e-6, 5.0914e-5, 2.9045e-6, 5.4109e-6),
    "varonet": (9.3437e-6, 1.6002e-4, 1.2522e-6, 3.7719e-6),
    "mambonet": (1.8749e-6, 2.1925e-5, 3.9598e-7, 6.4351e-7),
}
PHYSICAL = ("sho", "double_well", "morse", "mff", "smff")
#: The paper's physical-potential table (extended-data models; SMFF at alpha = 20).
PAPER_PHYSICAL = {
    "paper_rk4": (3.3663e-5, 1.4362e-2, 2.8753e-4, 1.5224e-4, 4.1551e-5),
    "deeponet": (2.4951e-4, 8.9770e-2, 4.7225e-2, 2.5406e-2, 1.5242e-2),
    "traonet": (1.0145e-6, 2.2207e-6, 7.6594e-6, 1.0228e-4, 3.3919e-5),
    "varonet": (1.9729e-7, 8.8354e-7, 2.3114e-6, 2.0465e-4, 7.2018e-5),
    "mambonet": (1.4197e-7, 4.3837e-7, 1.3451e-6, 1.3426e-4, 1.9754e-6),
}
STATS = ("mean", "std", "median", "iqr")


def _e(x):
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else f"{x:.2e}"


def _family(name, entry):
    return (entry.get("config") or {}).get("model", name.split("-")[0])


def _run_facts(entry):
    """(epochs, minutes) of a network's run directory, or None."""
    run = entry.get("run_dir")
    history = Path(run) / "history.csv" if run else None
    if history is None or not history.is_file():
        return None
    last = history.read_text().strip().splitlines()[-1].split(",")
    return int(last[0]), float(last[-1]) / 60


def tail(methods, test_path):
    """How much of each network's mean its worst potentials make: the mean of L_tot is
    ruled by a few potentials, the median and IQR by the bulk."""
    import numpy as np

    import nh_operators as nh

    test = nh.load_dataset(test_path)
    print(f"\nThe tail ({test_path}): each network's worst potentials")
    print("| network | worst index | its L_tot | its share of the mean | mean without it | "
          "mean without the worst 3 | its V at q = 0, 0.05, 0.1 | its period |")
    print("|---|---:|---:|---:|---:|---:|---|---:|")
    for name, entry in methods.items():
        if entry.get("kind") != "neural" or not entry.get("run_dir"):
            continue
        net, _ = nh.load_model(entry["run_dir"])
        q, p = nh.predict(net, test.V, nh.TIMES)
        loss = 0.5 * (((q - test.q) ** 2).mean(1) + ((p - test.p) ** 2).mean(1))
        order = np.argsort(loss)[::-1]
        worst = int(order[0])
        pot = test.potential(worst)
        values = ", ".join(f"{v:.2f}" for v in pot.V(np.array([0.0, 0.05, 0.1])))
        # a time beyond 2 makes solve find the orbit's period (docs/solve.md)
        period = nh.solve(pot, [3.0], tol=1e-6).tried[-1]["period"]
        print(f"| {name} | {worst} | {loss[worst]:.2e} | {loss[worst] / loss.sum():.0%} | "
              f"{np.delete(loss, order[:1]).mean():.2e} | "
              f"{np.delete(loss, order[:3]).mean():.2e} | {values} | {period:.3g} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--report", required=True, help="report.json of nh-operators evaluate")
    ap.add_argument("--json", help="also write the rows here")
    ap.add_argument("--tail", metavar="TEST.h5",
                    help="the report's test set: re-predict each network from its run "
                    "directory and print its worst potentials' share of the mean")
    args = ap.parse_args()
    report = json.loads(Path(args.report).read_text())
    methods = report["methods"]
    print(f"test set: {report.get('test_set', {}).get('path', '?')} "
          f"({report.get('test_set', {}).get('n', '?')} potentials)\n")
    print("| method | trained | mean L_tot | std | median | IQR | paper mean | paper std | "
          "paper median | paper IQR | mean / paper |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    rows = []
    for name, entry in methods.items():
        family = _family(name, entry) if entry.get("kind") == "neural" else name
        ours = [entry["test"].get(s) for s in STATS]
        paper = PAPER_10K.get(family)
        facts = _run_facts(entry)
        trained = (f"{facts[0]} ep, {facts[1]:.0f} min" if facts else
                   ("–" if entry.get("kind") != "neural" else "?"))
        ratio = f"{ours[0] / paper[0]:.2f}" if paper else "–"
        print(f"| {name} | {trained} | " + " | ".join(_e(v) for v in ours) + " | "
              + " | ".join(_e(v) for v in (paper or (None,) * 4)) + f" | {ratio} |")
        rows.append({"name": name, "family": family, "test": dict(zip(STATS, ours)),
                     "paper_10k": paper, "physical": entry.get("physical", {}),
                     "trained": facts})
    print("\nThe paper's 100k-data means, for scale: "
          + ", ".join(f"{k} {v[0]:.2e}" for k, v in PAPER_100K.items()))
    print("\n| method | " + " | ".join(PHYSICAL) + " |")
    print("|---|" + "---:|" * len(PHYSICAL))
    for row in rows:
        print(f"| {row['name']} | " + " | ".join(_e(row["physical"].get(p))
                                                 for p in PHYSICAL) + " |")
        if row["family"] in PAPER_PHYSICAL:
            label = ("the paper's RK4" if row["family"] == "paper_rk4"
                     else f"paper {row['family']} (100k data)")
            print(f"| {label} | "
                  + " | ".join(_e(v) for v in PAPER_PHYSICAL[row["family"]]) + " |")
    if args.tail:
        tail(methods, args.tail)
    devices = sorted({str(e.get("device")) for e in methods.values() if e.get("device")})
    print(f"\nevaluation device: {', '.join(devices) or '?'}")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
