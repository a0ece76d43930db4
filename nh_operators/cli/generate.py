"""``nh-operators generate``: a labelled dataset in HDF5."""

import time

from ..data import PRESETS, generate_dataset


def _generate(args):
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


def register(sub):
    """Add this module's commands to the subparsers ``sub``."""
    gen = sub.add_parser("generate", help="generate a labelled dataset (HDF5)")
    gen.add_argument("--preset", choices=["standard", "extended", "test"])
    gen.add_argument("--size", type=int, help="number of potentials")
    gen.add_argument("--seed", type=int, help="generator seed")
    gen.add_argument("--out", help="output .h5 file (default: PRESET.h5)")
    gen.add_argument("--chunk", type=int, default=2000, help="potentials per labelled chunk")
    gen.add_argument("--quiet", action="store_true", help="no progress bar")
    gen.set_defaults(run=_generate)
