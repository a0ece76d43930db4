"""The whole pipeline at small scale: generate, train, evaluate against the classical solvers.

Run: ``python examples/hamilton_1d.py [--out runs/hamilton_1d]`` (about 5 minutes on a
2-core CPU). It

1. draws bounded potentials with the paper's generator and labels them exactly
   (a training set and a test set, HDF5, resumable);
2. trains small networks (``cpu`` presets) in DeepXDE's loop, with a checkpoint per epoch;
3. evaluates them next to the classical baselines (RK4 on the sensors, the symplectic
   methods, the paper-replica RK4) on the test set and on the five physical potentials,
   with timings and the stability section, and writes ``report/report.md``,
   ``report/report.json`` and the figures.

Everything lands in ``--out``; run it again and finished steps are reused. The paper's
scale: ``--paper-scale`` (10,000 training potentials, the 4,000-potential test set, the
paper's architectures, 250 epochs: hours on a CPU; use ``--device cuda`` on a GPU).
"""

import argparse
import time
from pathlib import Path

import nh_operators as nh
from nh_operators.data import DATASET_PRESETS as PRESETS, generate_dataset
from nh_operators.evaluation import (
    EvaluationSettings,
    evaluate_report,
    physical_reference,
    plot_physical_potentials,
    save_figure,
)
from nh_operators.training import resolve_device


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/hamilton_1d", help="output folder")
    parser.add_argument("--train-size", type=int, default=2000, help="training potentials")
    parser.add_argument("--test-size", type=int, default=1000, help="test potentials")
    parser.add_argument("--models", nargs="+", default=["deeponet", "traonet"],
                        choices=sorted(nh.MODELS), help="networks to train")
    parser.add_argument("--preset", default="cpu", choices=["cpu", "paper"])
    parser.add_argument("--epochs", type=int, default=25)
    parser.add_argument("--seed", type=int, default=0, help="training seed")
    parser.add_argument("--device", default="auto", help="auto, cpu, cuda")
    parser.add_argument("--paper-scale", action="store_true",
                        help="standard/test presets, paper architectures, 250 epochs")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    args = parser.parse_args(argv)
    if args.paper_scale:
        args.train_size, args.test_size = PRESETS["standard"]["size"], PRESETS["test"]["size"]
        args.preset, args.epochs = "paper", 250
        args.models = ["deeponet", "traonet", "varonet", "mambonet"]
    return args


def main(argv=None):
    args = parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    progress = not args.quiet

    print(f"1. data: {args.train_size} training and {args.test_size} test potentials")
    train_path, test_path = out / "train.h5", out / "test.h5"
    generate_dataset(args.train_size, PRESETS["standard"]["seed"], train_path, progress=progress)
    generate_dataset(args.test_size, PRESETS["test"]["seed"], test_path, progress=progress)

    runs = []
    for name in args.models:
        run = out / "runs" / name
        print(f"2. training {name} ({args.preset} preset, {args.epochs} epochs) -> {run}")
        config = nh.TrainConfig(name, preset=args.preset, epochs=args.epochs, seed=args.seed,
                                device=args.device)
        _, history = nh.train(config, train_path, run, resume=True, progress=progress)
        last = history[-1]
        print(f"   validation loss {last['val_loss']:.3e} after {last['seconds'] / 60:.1f} min")
        runs.append(run)

    print("3. evaluating the networks and the classical baselines")
    device = str(resolve_device(args.device))
    settings = EvaluationSettings(n_single=10, n_batched=min(1000, args.test_size), repeats=3)
    report, results = evaluate_report(runs, test_path, out / "report", device=device,
                                      settings=settings, progress=progress,
                                      argv=["(examples/hamilton_1d.py)"])
    names = list(nh.PHYSICAL_POTENTIALS)
    print(f"\n{'method':<22}{'test mean L_tot':>16}" + "".join(f"{n:>13}" for n in names))
    for method, m in results["methods"].items():
        print(f"{method:<22}{m['test']['mean']:>16.3e}"
              + "".join(f"{m['physical'][n]:>13.3e}" for n in names))
    trajectories = {n: physical_reference(n) for n in names}
    save_figure(plot_physical_potentials(nh.PHYSICAL_POTENTIALS, trajectories),
                out / "report" / "physical_potentials.png")
    print(f"\nreport: {report}; figures in {report.parent}; "
          f"{(time.perf_counter() - start) / 60:.1f} min in all")


if __name__ == "__main__":
    main()
