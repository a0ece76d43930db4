"""Command line: ``nh-operators generate | demo | train | tune | evaluate | benchmark |
export | calibrate | predict``.

Thin: parse the arguments, then call the library.
"""

import argparse
import os
import sys
import time

MODELS = ["deeponet", "traonet", "varonet", "mambonet", "fno"]


def _generate(args):
    from .data import PRESETS, generate_dataset

    if args.preset:
        size, seed = PRESETS[args.preset]["size"], PRESETS[args.preset]["seed"]
        size = args.size or size
        seed = seed if args.seed is None else args.seed
        out = args.out or f"{args.preset}.h5"
    else:
        if args.size is None or args.seed is None or args.out is None:
            raise SystemExit("generate: give --preset, or all of --size, --seed and --out")
        size, seed, out = args.size, args.seed, args.out
    start = time.perf_counter()
    ds = generate_dataset(size, seed, out, chunk=args.chunk, progress=not args.quiet)
    seconds = time.perf_counter() - start
    dropped = ds.attrs.get("dropped", {})
    reasons = ", ".join(f"{k}: {v}" for k, v in dropped.items()) or "none"
    print(f"wrote {out}: {len(ds)} potentials (seed {seed}), dropped {ds.attrs['n_dropped']} "
          f"({reasons}), {seconds:.1f} s, checksum {ds.attrs['checksum']}")


def _demo(args):
    import warnings

    from ._constants import TIMES
    from .auto_solve import solve
    from .evaluate import CLASSICAL_BASELINES, classical_physical_table, physical_reference
    from .physical import PHYSICAL_POTENTIALS
    from .plots import plot_physical_potentials, plot_trajectory
    from .pretrained import available_pretrained, pretrained
    from .report_files import save_figure

    os.makedirs(args.out, exist_ok=True)
    networks = {name: pretrained(name) for name in available_pretrained()}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = classical_physical_table(baselines={**CLASSICAL_BASELINES, **networks})
    outside = sorted({str(w.message).split(":")[0] for w in caught
                      if type(w.message).__name__ == "OutOfDomainWarning"})
    names = list(PHYSICAL_POTENTIALS)
    print("Classical solvers and the shipped networks on the physical potentials: L_tot "
          "against the exact solution")
    print("(SHO, MFF) or DOP853 at 1e-13; sensor methods and networks see V at the 100 "
          "sensors only.\n")
    print(f"{'method':<22}" + "".join(f"{n:>13}" for n in names) + f"{'µs/traj':>10}")
    for method, row in table.items():
        micro = 1e6 * sum(row[n]["seconds"] for n in names) / len(names)
        print(f"{method:<22}" + "".join(f"{row[n]['L_tot']:>13.3e}" for n in names) + f"{micro:>10.0f}")
    if outside:
        print(f"\nOutside the training domain (extrapolation): {'; '.join(outside)}")
    trajectories = {n: physical_reference(n) for n in names}
    path = os.path.join(args.out, "physical_potentials.png")
    save_figure(plot_physical_potentials(PHYSICAL_POTENTIALS, trajectories), path)
    print(f"\nfigure: {path}")
    if networks:
        best = min(networks, key=lambda m: table[m]["double_well"]["L_tot"])
        pot = PHYSICAL_POTENTIALS["double_well"]
        sol = solve(pot, TIMES, method=best)
        q, p = trajectories["double_well"]
        path = os.path.join(args.out, f"double_well_{best}.png")
        save_figure(plot_trajectory(pot, TIMES, q, p, sol.q, sol.p, label=best,
                                    title=f"double well: {best} (estimated L_tot "
                                    f"{sol.error_estimate:.2g})"), path)
        print(f"figure: {path} (nh.solve('double_well', t, method={best!r}))")


def _predict(args):
    import numpy as np

    from ._constants import TIMES
    from .auto_solve import solve
    from .classical_solve import as_potential, solve_classical
    from .evaluate import loss_per_sample
    from .plots import plot_trajectory

    times = TIMES if args.times is None else np.asarray(args.times, dtype=np.float64)
    pot, _ = as_potential(args.potential)  # safe parse and the bounded checks
    sol = solve(pot, times, tol=args.tol, method=args.model)
    ref = solve_classical(pot, times, tol=1e-12, method="yoshida8")
    true = float(loss_per_sample(sol.q, sol.p, ref.q, ref.p)["L_tot"])
    formula = getattr(pot, "formula", args.potential)
    print(f"V(q) = {formula}")
    print(f"method: {sol.method} ({sol.kind}; {sol.reason}), {1e3 * sol.seconds:.2f} ms")
    print(f"estimated L_tot {sol.error_estimate:.3g}; L_tot against a Yoshida-8 solve at "
          f"1e-12: {true:.3g}" + ("" if args.tol is None else f"; tol {args.tol:g}"))
    rows = np.arange(times.size)
    if rows.size > args.rows:
        rows = np.unique(np.linspace(0, times.size - 1, args.rows).round().astype(int))
        print(f"({rows.size} of {times.size} times shown; --rows changes it)")
    print(f"{'t':>8} {'q':>12} {'p':>12} {'|q - ref|':>11} {'|p - ref|':>11}")
    for i in rows:
        print(f"{times[i]:8.4f} {sol.q[i]:12.6f} {sol.p[i]:12.6f} "
              f"{abs(sol.q[i] - ref.q[i]):11.2e} {abs(sol.p[i] - ref.p[i]):11.2e}")
    if args.out:
        order = np.argsort(times, kind="stable")
        fig = plot_trajectory(pot, times[order], ref.q[order], ref.p[order],
                              sol.q[order], sol.p[order], label=sol.method,
                              title=f"V(q) = {formula}: {sol.method}, L_tot {true:.2g}")
        from .report_files import save_figure

        save_figure(fig, args.out)
        print(f"figure: {args.out}")


def _calibrate(args):
    from .solve_calibration import calibrate_pretrained

    cal = calibrate_pretrained(args.model, args.data)
    print(f"{args.model}: factor {cal['factor']:.3g} = the larger 99.5 % quantile of L_tot / "
          f"(E + D): {cal['factor_in_distribution']:.3g} on {cal['n']} generator potentials, "
          f"{cal.get('factor_ood', 0):.3g} on {cal.get('n_ood', 0)} out-of-distribution ones; "
          f"median estimate {cal['estimate_quantiles'][5]:.3g}, median L_tot "
          f"{cal['L_quantiles'][5]:.3g}; network solve {1e6 * cal['neural_seconds']:.0f} µs")


def _arch_overrides(items):
    import ast

    arch = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--arch takes KEY=VALUE, got {item!r}")
        try:
            arch[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            arch[key] = value
    return arch


def _train(args):
    from .models import count_parameters
    from .train import TrainConfig, train
    from .tuning_spaces import tuned_train_kwargs

    tuned = tuned_train_kwargs(  # --config FILE, explicit flags on top
        args.config, model=args.model, preset=args.preset, arch=_arch_overrides(args.arch),
        lr=args.lr, upper_bound=args.upper_bound, infimum_lr=args.infimum_lr, beta=args.beta)
    config = TrainConfig(**tuned, epochs=args.epochs, seed=args.seed,
                         batch_size=args.batch_size, scheduler=args.scheduler,
                         dtype=args.dtype, device=args.device, amp=args.amp)
    net, history = train(config, args.data, args.out, resume=args.resume,
                         progress=not args.quiet, max_minutes=args.max_minutes,
                         stop_after=args.stop_after)
    last = history[-1]
    print(f"{config.model} ({config.preset}, {count_parameters(net)} parameters): "
          f"{last['epoch']} epochs in {last['seconds'] / 60:.1f} min, train loss "
          f"{last['train_loss']:.3e}, validation loss {last['val_loss']:.3e}; "
          f"run directory {args.out}")


def _tune(args):
    import optuna

    from .tuning import best_config, study_name, tune
    from .tuning_spaces import tuned_train_kwargs

    optuna.logging.set_verbosity(optuna.logging.WARNING)  # tune prints a line per trial
    if args.threads:
        import torch

        torch.set_num_threads(args.threads)
    base = tuned_train_kwargs(args.config, model=args.model, arch=_arch_overrides(args.arch))
    model = base.pop("model")
    out = args.out or (args.study or study_name(model, args.stage, args.space)) + ".json"
    study = tune(model, args.stage, args.data, n_trials=args.trials, timeout=args.timeout,
                 storage=args.storage, space=args.space, study=args.study,
                 epochs=args.epochs, seeds=args.seeds, base=base, workdir=args.workdir,
                 out=out, device=args.device)
    best = best_config(study)
    if best is None:
        print(f"{study.study_name}: no trial has completed yet; nothing written")
        return
    info = best["tuning"]
    params = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                       for k, v in info["params"].items())
    print(f"{study.study_name}: best trial {info['trial']} of {sum(info['trials'].values())}"
          f" ({params}): mean validation loss {info['value']:.4g}; written to {out} "
          f"(nh-operators train --config {out} ...)")


def _settings(args):
    from .report import EvaluationSettings

    return EvaluationSettings(n_unbatched=args.unbatched_size, n_single=args.n_single,
                              n_batched=args.batched_size, repeats=args.repeats,
                              timing=not args.no_timing)


def _classical(args, default):
    if args.classical is None:
        return default
    return [] if args.classical == ["none"] else args.classical


def _evaluate(args):
    from .methods import EVALUATE_BASELINES
    from .study import evaluate_report

    path, results = evaluate_report(
        args.runs or [], args.test, args.out, classical=_classical(args, EVALUATE_BASELINES),
        device=args.device, settings=_settings(args), stability=not args.no_stability,
        figures=not args.no_figures, fresh=args.fresh, progress=not args.quiet,
        argv=args.argv)
    from .report_files import test_table

    print(test_table(results))
    print(f"\nreport: {path} (and report.json, figures, in {args.out})")


def _benchmark(args):
    from .study import benchmark_report, statements
    from .workprecision import work_precision_markdown

    path, results = benchmark_report(
        args.test, args.out, args.runs or [], classical=_classical(args, None),
        device=args.device, settings=_settings(args), figures=not args.no_figures,
        fresh=args.fresh, progress=not args.quiet, argv=args.argv)
    print(work_precision_markdown(results).split("\n\n")[0])
    print("\n" + "\n".join(statements(results)))
    print(f"\nwork precision: {path}")


def _export(args):
    from .pretrained import export_pretrained

    out = export_pretrained(args.run_dir, args.out, report=args.report, name=args.name,
                            commands=args.command or [])
    size = sum(f.stat().st_size for f in out.iterdir())
    print(f"exported {args.run_dir} to {out} ({size / 1e6:.2f} MB)")


def _add_evaluation_options(parser):
    parser.add_argument("--test", required=True,
                        help="labelled test set .h5 (nh-operators generate --preset test)")
    parser.add_argument("--run", action="append", metavar="RUN_DIR", dest="runs",
                        help="run directory of a trained network, repeatable")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--classical", nargs="+", metavar="NAME",
                        help="classical baselines by name (see nh_operators.methods."
                             "CLASSICAL_METHODS), or 'none'")
    parser.add_argument("--device", default="cpu", help="device for the networks (cpu, cuda)")
    parser.add_argument("--repeats", type=int, default=5, help="timed calls, median kept")
    parser.add_argument("--n-single", type=int, default=20,
                        help="potentials timed one at a time (batch 1)")
    parser.add_argument("--batched-size", type=int, default=1000,
                        help="potentials in the batched timing call")
    parser.add_argument("--unbatched-size", type=int, default=200,
                        help="test potentials for one-at-a-time solvers (DOP853)")
    parser.add_argument("--no-timing", action="store_true", help="skip the timings")
    parser.add_argument("--no-figures", action="store_true", help="skip the figures")
    parser.add_argument("--fresh", action="store_true",
                        help="recompute every method (ignore OUT/cache)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def build_parser():
    parser = argparse.ArgumentParser(prog="nh-operators", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    gen = sub.add_parser("generate", help="generate a labelled dataset (HDF5)")
    gen.add_argument("--preset", choices=["standard", "extended", "test"])
    gen.add_argument("--size", type=int, help="number of potentials")
    gen.add_argument("--seed", type=int, help="generator seed")
    gen.add_argument("--out", help="output .h5 file (default: PRESET.h5)")
    gen.add_argument("--chunk", type=int, default=2000, help="potentials per labelled chunk")
    gen.add_argument("--quiet", action="store_true", help="no progress bar")
    gen.set_defaults(run=_generate)
    demo = sub.add_parser("demo", help="classical solvers on the physical potentials")
    demo.add_argument("--out", default="demo", help="folder for the figure")
    demo.set_defaults(run=_demo)
    tr = sub.add_parser("train", help="train a network in DeepXDE's loop")
    tr.add_argument("--model", choices=MODELS, help="the network (or from --config)")
    tr.add_argument("--config", metavar="FILE.json", help="tuned values (nh-operators "
                    "tune --out): arch, lr, upper bound, infimum, beta; flags win")
    tr.add_argument("--preset", choices=["paper", "cpu"],
                    help="architecture preset (default: the config's, else cpu)")
    tr.add_argument("--data", required=True, help="dataset .h5 (nh-operators generate)")
    tr.add_argument("--epochs", type=int, default=10)
    tr.add_argument("--seed", type=int, default=0)
    tr.add_argument("--out", required=True, help="run directory")
    tr.add_argument("--resume", action="store_true", help="continue a killed run in --out")
    tr.add_argument("--max-minutes", type=float,
                    help="wall-time budget over the whole run; stops after the epoch "
                         "that passes it (checkpoint kept, --resume continues)")
    tr.add_argument("--stop-after", type=int, metavar="EPOCH",
                    help="stop after this epoch of the --epochs schedule (reproduces a "
                         "run that --max-minutes cut)")
    tr.add_argument("--arch", action="append", metavar="KEY=VALUE",
                    help="architecture override, repeatable (e.g. --arch d_model=64)")
    tr.add_argument("--batch-size", type=int, default=100)
    tr.add_argument("--lr", type=float, help="initial learning rate (default: paper's)")
    tr.add_argument("--upper-bound", type=float, help="schedule upper bound U")
    tr.add_argument("--infimum-lr", type=float, help="schedule infimum")
    tr.add_argument("--beta", type=float, help="KL weight (VaRONet)")
    tr.add_argument("--scheduler", default="exphyperbolic",
                    choices=["exphyperbolic", "hyperbolic", "constant"])
    tr.add_argument("--dtype", default="float32", choices=["float32", "float64"])
    tr.add_argument("--device", default="auto", help="auto, cpu, cuda, cuda:N")
    tr.add_argument("--amp", action="store_true", help="float16 autocast (CUDA only)")
    tr.add_argument("--quiet", action="store_true", help="no progress bar")
    tr.set_defaults(run=_train)
    tu = sub.add_parser("tune", help="tune with Optuna: stage grid (architecture) or tpe "
                        "(lr, upper bound, infimum, beta); workers may share a study")
    tu.add_argument("--model", choices=MODELS, help="the network (or from --config)")
    tu.add_argument("--stage", required=True, choices=["grid", "tpe"])
    tu.add_argument("--data", required=True, help="dataset .h5 (validation part scores)")
    tu.add_argument("--trials", type=int, help="trials of this worker (default: the "
                    "rest of the grid; tpe needs --trials or --timeout)")
    tu.add_argument("--timeout", type=float, metavar="MINUTES", help="start no trial after")
    tu.add_argument("--storage", default="sqlite:///tune.db", help="Optuna RDB URL")
    tu.add_argument("--study", help="study name (default: MODEL-STAGE-SPACE)")
    tu.add_argument("--space", default="cpu", help="search space: cpu, paper or FILE.json")
    tu.add_argument("--epochs", type=int, help="epochs per run (default: the space's)")
    tu.add_argument("--seeds", type=int, help="runs per trial, averaged (default: space's)")
    tu.add_argument("--config", metavar="FILE.json", help="start from these values (the "
                    "grid stage's best for tpe)")
    tu.add_argument("--arch", action="append", metavar="KEY=VALUE", help="architecture "
                    "override, repeatable")
    tu.add_argument("--out", help="best configuration, JSON (default: STUDY.json)")
    tu.add_argument("--workdir", help="keep run directories here (default: temporary)")
    tu.add_argument("--device", default="auto", help="auto, cpu, cuda, cuda:N")
    tu.add_argument("--threads", type=int, help="torch threads of this worker (CPU: cores "
                    "left free / workers; 1 on a busy machine)")
    tu.set_defaults(run=_tune)
    ev = sub.add_parser("evaluate", help="score runs and classical baselines: report.md, "
                        "report.json, figures")
    _add_evaluation_options(ev)
    ev.add_argument("--no-stability", action="store_true",
                    help="skip the stability-at-the-extremes section")
    ev.set_defaults(run=_evaluate)
    be = sub.add_parser("benchmark", help="the speed/accuracy (work-precision) study")
    _add_evaluation_options(be)
    be.set_defaults(run=_benchmark)
    ex = sub.add_parser("export", help="a run's weights, config, log and metrics as a "
                        "shippable folder (nh_operators/weights/NAME)")
    ex.add_argument("--run", required=True, dest="run_dir", help="run directory")
    ex.add_argument("--out", required=True, help="destination folder")
    ex.add_argument("--report", help="report.json of nh-operators evaluate with this run")
    ex.add_argument("--name", help="the model's name in the report (default: its model)")
    ex.add_argument("--command", action="append",
                    help="a command that regenerates it (repeatable, stored in metrics.json)")
    ex.set_defaults(run=_export)
    ca = sub.add_parser("calibrate", help="calibrate a shipped model's error estimate for "
                        "solve (writes nh_operators/weights/NAME/calibration.json)")
    ca.add_argument("--model", required=True, help="a shipped model")
    ca.add_argument("--data", required=True, help="labelled .h5 from neither the training "
                    "nor the test seed (e.g. generate --size 2000 --seed 2718)")
    ca.set_defaults(run=_calibrate)
    pr = sub.add_parser("predict", help="one potential typed as a formula: the trajectory "
                        "table and figure")
    pr.add_argument("--potential", required=True, help="an expression in q, e.g. "
                    "'8*(q-0.5)**2', or a physical potential's name (sho, ...)")
    pr.add_argument("--model", default="auto", help="auto (default), classical, an "
                    "integrator, or a shipped model (deeponet, traonet, ...)")
    pr.add_argument("--times", type=float, nargs="+", help="query times (default: the "
                    "100-point grid on [0, 2])")
    pr.add_argument("--tol", type=float, help="target L_tot (auto picks the method)")
    pr.add_argument("--rows", type=int, default=20, help="table rows at most (default 20)")
    pr.add_argument("--out", help="figure file (.png, .pdf, .svg)")
    pr.set_defaults(run=_predict)
    return parser


def main(argv=None):
    args = build_parser().parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
    from .train import TrainingDiverged

    try:
        args.run(args)
    except (ValueError, FileNotFoundError, FileExistsError) as err:
        print(f"nh-operators {args.command}: error: {err}", file=sys.stderr)
        return 2
    except TrainingDiverged as err:
        print(f"nh-operators {args.command}: {err}", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main())
