"""``nh-operators export`` and ``calibrate``: a run as shippable weights, and its calibration."""

from ._options import existing_dir, existing_file


def _export(args):
    from ..solving import export_pretrained

    out = export_pretrained(args.run_dir, args.out, report=args.report, name=args.name,
                            commands=args.command or [], data=args.data)
    size = sum(f.stat().st_size for f in out.iterdir())
    print(f"exported {args.run_dir} to {out} ({size / 1e6:.2f} MB)")


def _calibrate(args):
    from ..solving import calibrate_pretrained

    cal = calibrate_pretrained(args.model, args.data)
    print(f"{args.model}: factor {cal['factor']:.3g} = the larger 99.5 % quantile of L_tot / "
          f"(E + D): {cal['factor_in_distribution']:.3g} on {cal['n']} generator potentials, "
          f"{cal.get('factor_ood', 0):.3g} on {cal.get('n_ood', 0)} out-of-distribution ones; "
          f"median estimate {cal['estimate_quantiles'][5]:.3g}, median L_tot "
          f"{cal['L_quantiles'][5]:.3g}; network solve {1e6 * cal['neural_seconds']:.0f} µs")


def register(sub):
    """Add this module's commands to the subparsers ``sub``."""
    ex = sub.add_parser("export", help="a run's weights, config, log and metrics as a "
                        "shippable folder (nh_operators/solving/weights/NAME)")
    ex.add_argument("--run", required=True, dest="run_dir", type=existing_dir,
                    help="run directory")
    ex.add_argument("--out", required=True, help="destination folder")
    ex.add_argument("--report", type=existing_file, help="report.json of nh-operators evaluate with this run")
    ex.add_argument("--name", help="the model's name in the report (default: its model)")
    ex.add_argument("--command", action="append",
                    help="a command that regenerates it (repeatable, stored in metrics.json)")
    ex.add_argument("--data", type=existing_file,
                    help="the run's training .h5: writes domain.json, the inputs solve "
                    "hands this network (fitted to its training rows)")
    ex.set_defaults(run=_export)
    ca = sub.add_parser("calibrate", help="calibrate a shipped model's error estimate for "
                        "solve (writes nh_operators/solving/weights/NAME/calibration.json)")
    ca.add_argument("--model", required=True, help="a shipped model")
    ca.add_argument("--data", required=True, type=existing_file, help="labelled .h5 from neither the training "
                    "nor the test seed (e.g. generate --size 2000 --seed 2718)")
    ca.set_defaults(run=_calibrate)
