"""``nh-operators evaluate`` and ``benchmark``: reports in the paper's layout, work precision."""

from ._options import existing_dir, existing_file, positive_int


def _settings(args):
    from ..evaluation import EvaluationSettings

    return EvaluationSettings(n_unbatched=args.unbatched_size, n_single=args.n_single,
                              n_batched=args.batched_size, repeats=args.repeats,
                              timing=not args.no_timing)


def _classical(args, default):
    if args.classical is None:
        return default
    return [] if args.classical == ["none"] else args.classical


def _add_evaluation_options(parser):
    parser.add_argument("--test", required=True, type=existing_file,
                        help="labelled test set .h5 (nh-operators generate --preset test)")
    parser.add_argument("--run", action="append", metavar="RUN_DIR", dest="runs",
                        type=existing_dir,
                        help="run directory of a trained network, repeatable")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--classical", nargs="+", metavar="NAME",
                        help="classical baselines by name (see nh_operators.evaluation.methods."
                             "CLASSICAL_METHODS), or 'none'")
    parser.add_argument("--device", default="cpu", help="device for the networks (cpu, cuda)")
    parser.add_argument("--repeats", type=positive_int, default=5, help="timed calls, median kept")
    parser.add_argument("--n-single", type=positive_int, default=20,
                        help="potentials timed one at a time (batch 1)")
    parser.add_argument("--batched-size", type=positive_int, default=1000,
                        help="potentials in the batched timing call")
    parser.add_argument("--unbatched-size", type=positive_int, default=200,
                        help="test potentials for one-at-a-time solvers (DOP853)")
    parser.add_argument("--no-timing", action="store_true", help="skip the timings")
    parser.add_argument("--no-figures", action="store_true", help="skip the figures")
    parser.add_argument("--fresh", action="store_true",
                        help="recompute every method (ignore OUT/cache)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def _evaluate(args):
    from ..evaluation import EVALUATE_BASELINES, evaluate_report, test_table

    path, results = evaluate_report(
        args.runs or [], args.test, args.out, classical=_classical(args, EVALUATE_BASELINES),
        device=args.device, settings=_settings(args), stability=not args.no_stability,
        figures=not args.no_figures, fresh=args.fresh, progress=not args.quiet,
        argv=args.argv)
    print(test_table(results))
    print(f"\nreport: {path} (and report.json, figures, in {args.out})")


def _benchmark(args):
    from ..evaluation import benchmark_report, work_precision_markdown
    from ..evaluation.study import statements

    path, results = benchmark_report(
        args.test, args.out, args.runs or [], classical=_classical(args, None),
        device=args.device, settings=_settings(args), figures=not args.no_figures,
        fresh=args.fresh, progress=not args.quiet, argv=args.argv)
    print(work_precision_markdown(results).split("\n\n")[0])
    print("\n" + "\n".join(statements(results)))
    print(f"\nwork precision: {path}")


def register(sub):
    """Add this module's commands to the subparsers ``sub``."""
    ev = sub.add_parser("evaluate", help="score runs and classical baselines: report.md, "
                        "report.json, figures")
    _add_evaluation_options(ev)
    ev.add_argument("--no-stability", action="store_true",
                    help="skip the stability-at-the-extremes section")
    ev.set_defaults(run=_evaluate)
    be = sub.add_parser("benchmark", help="the speed/accuracy (work-precision) study")
    _add_evaluation_options(be)
    be.set_defaults(run=_benchmark)
