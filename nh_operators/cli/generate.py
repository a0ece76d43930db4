"""``nh-operators generate``: a labelled dataset in HDF5."""

import sys
import time

from .._dataset_presets import DATASET_PRESETS
from ._options import nonnegative_int, positive_int

#: The dataset presets (a table without torch, shared with the data wing).
PRESETS = DATASET_PRESETS  # the choices of --preset


def _plan(args):
    """(size, seed, out, generator options) from a preset and/or flags; says when a flag
    overrides a preset."""
    if args.preset:
        preset = dict(PRESETS[args.preset])
        size, seed = preset.pop("size"), preset.pop("seed")
        for flag, given, default in (("--size", args.size, size), ("--seed", args.seed, seed)):
            if given is not None and given != default:
                print(f"note: {flag} {given} overrides the {args.preset} preset's {default}",
                      file=sys.stderr)
        if args.size is not None and args.size != size:
            preset.pop("pool", None)  # then 1.25 (size + skip) candidates, as the code draws
        size = size if args.size is None else args.size
        seed = seed if args.seed is None else args.seed
        return size, seed, args.out or f"{args.preset}.h5", preset
    missing = [f for f, v in (("--size", args.size), ("--seed", args.seed), ("--out", args.out))
               if v is None]
    if missing:
        raise ValueError(f"give --preset, or all of --size, --seed and --out (missing: "
                         f"{', '.join(missing)})")
    return args.size, args.seed, args.out, {}


def _generate(args):
    from ..data import check_output_path, generate_dataset

    size, seed, out, options = _plan(args)
    if args.normalization and args.normalization != options.get("normalization", "potential"):
        if args.preset:
            print(f"note: --normalization {args.normalization} overrides the {args.preset} "
                  "preset's", file=sys.stderr)
        options["normalization"] = args.normalization
        if args.normalization == "potential":
            options.pop("pool", None)
    if args.states is not None:
        if args.preset and args.states != options.get("states", "rest"):
            print(f"note: --states {args.states} overrides the {args.preset} preset's",
                  file=sys.stderr)
        options["states"] = args.states
    if options.get("states") == "rest":
        options.pop("states")
    if args.separatrix_share is not None:
        if options.get("states") != "energy":
            raise ValueError("--separatrix-share needs --states energy (or a -states- preset)")
        options["separatrix_share"] = args.separatrix_share
    args.output = out  # for the message if interrupted
    check_output_path(out, force=args.force)  # before any work
    start = time.perf_counter()
    ds = generate_dataset(size, seed, out, chunk=args.chunk, progress=not args.quiet,
                          force=args.force, **options)
    seconds = time.perf_counter() - start
    dropped = ds.attrs.get("dropped", {})
    reasons = ", ".join(f"{k}: {v}" for k, v in dropped.items()) or "none"
    print(f"wrote {out}: {len(ds)} potentials (seed {seed}), dropped {ds.attrs['n_dropped']} "
          f"({reasons}), {seconds:.1f} s, checksum {ds.attrs['checksum']}")


def _interrupted(args):
    from ..data import partial_progress

    out = getattr(args, "output", None)
    done = partial_progress(out) if out else None
    if not done:
        return "nothing was written"
    return (f"{done[0]} of {done[1]} potentials kept in {out}.partial; run the same command "
            "again to resume")


def register(sub):
    """Add this module's commands to the subparsers ``sub``."""
    gen = sub.add_parser(
        "generate", help="generate a labelled dataset (HDF5)",
        description="Generate a labelled dataset. Give --preset NAME, or all three of --size, "
                    "--seed and --out. Presets alg1-standard, alg1-extended, alg1-test (also "
                    "called standard, extended, test) follow Algorithm 1 as printed; "
                    "paper-standard, paper-extended, paper-test follow the reference code "
                    "that made the paper's tables (--normalization batch); the -states- "
                    "presets hold the same potentials, each started from its own bounded "
                    "state stratified by energy (--states energy). An interrupted "
                    "run resumes when run again; a finished file is replaced only with --force.")
    gen.add_argument("--preset", choices=list(PRESETS),
                     help="a named dataset of the paper (then --size/--seed override it)")
    gen.add_argument("--size", type=positive_int,
                     help="number of potentials (required without --preset)")
    gen.add_argument("--seed", type=nonnegative_int,
                     help="generator seed, an integer ≥ 0 (required without --preset)")
    gen.add_argument("--out", help="output .h5 file (required without --preset; default: "
                                   "PRESET.h5)")
    gen.add_argument("--normalization", choices=["potential", "batch"],
                     help="potential: Algorithm 1 as printed (default); batch: the reference "
                          "code, 1.25 n candidates normalised together")
    gen.add_argument("--states", choices=["rest", "energy"],
                     help="rest: the paper's start at rest at q = 0 (default); energy: a "
                          "bounded starting state per potential, stratified by energy")
    gen.add_argument("--separatrix-share", type=float, metavar="SHARE",
                     help="with --states energy: the share of states drawn near a "
                          "separatrix (default 0.25)")
    gen.add_argument("--chunk", type=positive_int, default=2000,
                     help="potentials per labelled chunk (default 2000)")
    gen.add_argument("--force", action="store_true", help="replace a finished file at --out")
    gen.add_argument("--quiet", action="store_true", help="no progress bar")
    gen.set_defaults(run=_generate, interrupted=_interrupted)
