"""Command line: ``nh-operators generate`` and ``nh-operators demo`` (parse, then call)."""

import argparse
import os
import sys
import time


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
    from .evaluate import classical_physical_table, physical_reference
    from .physical import PHYSICAL_POTENTIALS
    from .plots import plot_physical_potentials

    os.makedirs(args.out, exist_ok=True)
    table = classical_physical_table()
    names = list(PHYSICAL_POTENTIALS)
    print("Classical solvers on the physical potentials: L_tot against the exact solution")
    print("(SHO, MFF) or DOP853 at 1e-13; sensor methods see V at the 100 sensors only.\n")
    print(f"{'method':<22}" + "".join(f"{n:>13}" for n in names) + f"{'µs/traj':>10}")
    for method, row in table.items():
        micro = 1e6 * sum(row[n]["seconds"] for n in names) / len(names)
        print(f"{method:<22}" + "".join(f"{row[n]['L_tot']:>13.3e}" for n in names) + f"{micro:>10.0f}")
    trajectories = {n: physical_reference(n) for n in names}
    fig = plot_physical_potentials(PHYSICAL_POTENTIALS, trajectories)
    path = os.path.join(args.out, "physical_potentials.png")
    fig.savefig(path, dpi=110)
    print(f"\nfigure: {path}")


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
    return parser


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        args.run(args)
    except (ValueError, FileNotFoundError) as err:
        print(f"nh-operators {args.command}: error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
