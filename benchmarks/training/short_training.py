"""Short training runs of every network on the standard dataset, scored on the test set.

    nh-operators generate --preset standard --out standard.h5
    nh-operators generate --preset test --out test.h5
    python benchmarks/training/short_training.py --data standard.h5 --test test.h5 \
        --epochs 10 --preset cpu --out runs/short

Each model trains through ``nh_operators.train`` (DeepXDE's loop, the paper's
optimiser and schedule values, seed 0) into ``OUT/NAME``; a finished or interrupted run
is resumed rather than restarted. The table gives the wall time, the last validation
loss and the test-set per-sample L_tot (mean, median) of the final weights.
"""

import argparse
import time

import numpy as np

import nh_operators as nh
from nh_operators.data import load_dataset
from nh_operators.evaluation import loss_per_sample


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", required=True)
    parser.add_argument("--test", required=True)
    parser.add_argument("--models", default=",".join(nh.MODELS))
    parser.add_argument("--preset", default="cpu")
    parser.add_argument("--epochs", type=int, default=10)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="runs/short")
    args = parser.parse_args()
    data, test = load_dataset(args.data), load_dataset(args.test)
    rows = []
    for name in args.models.split(","):
        config = nh.TrainConfig(name, preset=args.preset, epochs=args.epochs,
                                seed=args.seed)
        start = time.perf_counter()
        net, history = nh.train(config, data, f"{args.out}/{name}", resume=True)
        wall = time.perf_counter() - start
        q, p = nh.predict(net, test.V, test.t, batch_size=500)
        loss = loss_per_sample(q, p, test.q, test.p)["L_tot"]
        rows.append((name, nh.count_parameters(net), history[-1]["seconds"] / 60, wall,
                     history[-1]["val_loss"], float(np.mean(loss)),
                     float(np.median(loss))))
        print(f"{name}: done", flush=True)
    print(f"\n{args.preset} preset, {args.epochs} epochs on {args.data}, test {args.test}")
    print(f"{'model':<10}{'params':>10}{'train min':>11}{'val loss':>11}"
          f"{'test mean L_tot':>17}{'test median':>13}")
    for name, params, minutes, _, val, mean, median in rows:
        print(f"{name:<10}{params:>10,}{minutes:>11.1f}{val:>11.3e}{mean:>17.3e}"
              f"{median:>13.3e}")


if __name__ == "__main__":
    main()
