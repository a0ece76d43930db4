"""Two or more training runs side by side: validation loss at equal epochs or wall clock.

Reads each run's ``history.csv`` (``nh_operators.training.read_history``) and prints one
row per asked epoch (validation loss and minutes), plus each run's last epoch; with
``--minutes``, one row per asked wall-clock time instead (the validation loss of the last
epoch finished by then, and that epoch).

Run it with::

    python benchmarks/training/compare_histories.py RUN_A RUN_B [--epochs 10 25 50 100 200]
    python benchmarks/training/compare_histories.py RUN_A RUN_B --minutes 1 2 4
"""

import argparse

from nh_operators.training import read_history


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", help="run directories (or shipped weights folders)")
    ap.add_argument("--epochs", type=int, nargs="+", default=[10, 25, 50, 100, 200])
    ap.add_argument("--minutes", type=float, nargs="+",
                    help="compare at these wall-clock times instead of at epochs")
    args = ap.parse_args()
    histories = [read_history(run) for run in args.runs]
    if args.minutes:
        return at_minutes(args.runs, histories, args.minutes)
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


def at_minutes(runs, histories, minutes):
    """One row per wall-clock time: each run's last finished epoch by then."""
    print("| minutes | " + " | ".join(f"{run}: validation | epoch" for run in runs) + " |")
    print("|---|" + "---:|---:|" * len(runs))
    for limit in minutes:
        cells = []
        for h in histories:
            done = [i for i, sec in enumerate(h["seconds"]) if sec <= 60 * limit]
            cells.append(f"{h['val_loss'][done[-1]]:.2e} | {int(h['epoch'][done[-1]])}"
                         if done else "– | –")
        print(f"| {limit:g} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
