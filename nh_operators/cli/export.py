"""``nh-operators export`` and ``calibrate``: a run as shippable weights, and its calibration."""

from ._options import existing_dir, existing_file


def _export(args):
    from ..solving import export_pretrained

    out = export_pretrained(args.run_dir, args.out, report=args.report, name=args.name,
                            commands=args.command or [], data=args.data)
    size = sum(f.stat().st_size for f in out.iterdir())
    print(f"exported {args.run_dir} to {out} ({size / 1e6:.2f} MB)")


def _calibrate(args):
    from pathlib import Path

    from ..data import load_dataset
    from ..solving import calibrate_pretrained, resolve_pretrained

    other = load_dataset(args.other).potentials() if args.other else None
    measure = "costs" if args.timings_only else "factors" if args.keep_timings else "all"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for model in args.model:
        name = resolve_pretrained(model)
        path = out / name / "calibration.json"
        path.parent.mkdir(exist_ok=True)
        cal = calibrate_pretrained(name, args.data, other=other, measure=measure, out=path)
        fams = "; ".join(
            f"{fam} {f['admitted']}/{f['drawn']}"
            + (f", median {f['ratio_median']:.2g}, per bin " if f["admitted"] else "")
            + ", ".join(f"{c['n']} (bound {c['bound']:.3g})" if c["n"] else "0"
                        for c in f["bins"] if f["admitted"])
            for fam, f in cal.families.items())
        bins = ", ".join(f"{f:.3g}" for f in cal.factors[("bspline", "plain")])
        bins += " (sensor values: " + ", ".join(
            f"{f:.3g}" for f in cal.factors[("sensors", "plain")]) + ")"
        print(f"{model}: factors {bins} for raw estimates split at "
              f"{', '.join(f'{x:g}' for x in cal.limits)} (the largest bounds on the "
              f"{100 * cal.info['quantile']:g} % quantile of true L_tot / raw estimate, "
              f"{100 * cal.info['confidence']:g} % confidence; {fams}); "
              f"median estimate / true in distribution "
              f"{cal.info.get('estimate_over_true_median', float('nan')):.3g}; network "
              f"solve {1e6 * cal.neural_seconds:.0f} µs; written to {path}", flush=True)


def register(sub):
    """Add this module's commands to the subparsers ``sub``."""
    ex = sub.add_parser("export", help="a run's weights, config, log and metrics as a "
                        "shippable folder (nh_operators/solving/weights/NAME)")
    ex.add_argument("--run", required=True, dest="run_dir", type=existing_dir,
                    help="run directory")
    ex.add_argument("--out", required=True, help="destination folder")
    ex.add_argument("--report", type=existing_file,
                    help="report.json of nh-operators evaluate with this run")
    ex.add_argument("--name", help="the model's name in the report (default: its model)")
    ex.add_argument("--command", action="append",
                    help="a command that regenerates it (repeatable, stored in metrics.json)")
    ex.add_argument("--data", type=existing_file,
                    help="the run's training .h5: writes domain.json, the inputs solve "
                    "hands this network (fitted to its training rows)")
    ex.set_defaults(run=_export)
    ca = sub.add_parser("calibrate", help="calibrate a shipped model's error estimate for "
                        "solve (writes OUT/NAME/calibration.json; copy it into "
                        "nh_operators/solving/weights/NAME/ to ship it)")
    ca.add_argument("--model", required=True, nargs="+", help="shipped model(s)")
    ca.add_argument("--data", required=True, type=existing_file, help="labelled .h5 of the "
                    "models' own distribution from neither the training nor the test seed "
                    "(e.g. generate --size 2000 --seed 2718)")
    ca.add_argument("--other", type=existing_file, help=".h5 of the other generator's "
                    "potentials (those inside a model's domain join its calibration)")
    ca.add_argument("--out", required=True, help="folder to write NAME/calibration.json "
                    "into (never the installed package unless you name it)")
    when = ca.add_mutually_exclusive_group()
    when.add_argument("--timings-only", action="store_true", help="keep the factor; measure "
                      "the network's and the classical solve's times again (quiet machine)")
    when.add_argument("--keep-timings", action="store_true", help="calibrate the factors "
                      "again and keep the stored times (measured on a quiet machine)")
    ca.set_defaults(run=_calibrate)
