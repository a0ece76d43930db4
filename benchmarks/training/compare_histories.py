"""Two or more training runs side by side: validation loss and minutes at equal epochs.

Reads each run's ``history.csv`` (``nh_operators.training.read_history``) and prints one
row per asked epoch, plus each run's last epoch.

Run it with::

    python benchmarks/training/compare_histories.py RUN_A RUN_B [--epochs 10 25 50 100 200]
"""

import argparse

from nh_operators.training import read_history


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", help="run directories (or shipped weights folders)")
    ap.add_argument("--epochs", type=int, nargs="+", default=[10, 25, 50, 100, 200])
    args = ap.parse_args()
    histories = [read_history(run) for run in args.runs]
    print("| epoch | " + " | ".join(f"{run}: validation | minutes" for run in args.runs)
          + " |")
    print("|---|" + "---:|---:|" * len(args.runs))

    def cell(h, i):
        return f"{h['val_loss'][i]:.2e} | {h['seconds'][i] / 60:.1f}"

    for epoch in args.epochs:
        cells = []
        for h in histories:
            at = [i for i, e in enumerate(h["epoch"]) if e == epoch]
            cells.append(cell(h, at[0]) if at else "– | –")
        print(f"| {epoch} | " + " | ".join(cells) + " |")
    print("| end | " + " | ".join(f"{cell(h, -1)} (epoch {int(h['epoch'][-1])})"
                                  for h in histories) + " |")


if __name__ == "__main__":
    main()
