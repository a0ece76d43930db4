"""Command line: ``nh-operators generate | demo | train | tune | evaluate | benchmark |
export | calibrate | predict``.

Thin: parse the arguments, then call the library. Each command family lives in its own
module with a ``register(sub)`` that adds its subcommands.
"""

import sys

from . import evaluation, export, generate, predict, training
from ._options import Parser

__all__ = ["build_parser", "main"]


def build_parser():
    """The ``nh-operators`` argument parser with every subcommand."""
    parser = Parser(prog="nh-operators", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    for family in (generate, predict, training, evaluation, export):
        family.register(sub)
    return parser


def main(argv=None):
    """Run ``nh-operators`` with ``argv`` (default: ``sys.argv[1:]``); return the exit code."""
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as done:  # --help, or a bad option (one line printed already)
        return done.code if isinstance(done.code, int) else 2
    args.argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args.run(args)
    except KeyboardInterrupt:
        note = getattr(args, "interrupted", None)
        print(f"nh-operators {args.command}: interrupted; "
              f"{note(args) if note else 'nothing to resume'}", file=sys.stderr)
        return 130
    except (ValueError, OSError) as err:  # OSError: missing, existing, unwritable paths
        print(f"nh-operators {args.command}: error: {_one_line(err)}", file=sys.stderr)
        return 2
    except RuntimeError as err:
        from ..training.config import TrainingDiverged  # only on this path: it loads torch
        from ..training.distributed import RankFailed

        if not isinstance(err, (TrainingDiverged, RankFailed)):
            raise
        print(f"nh-operators {args.command}: {_one_line(err)}", file=sys.stderr)
        return 3
    return 0


def _one_line(err):
    text = str(err) if not isinstance(err, OSError) or not err.filename else (
        f"{err.strerror or err}: {err.filename!r}")
    return " ".join(text.split())


if __name__ == "__main__":
    sys.exit(main())
