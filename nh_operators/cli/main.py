"""Command line: ``nh-operators generate | demo | train | tune | evaluate | benchmark |
export | calibrate | predict``.

Thin: parse the arguments, then call the library. Each command family lives in its own
module with a ``register(sub)`` that adds its subcommands.
"""

import argparse
import sys

from ..training import TrainingDiverged
from . import evaluation, export, generate, predict, training

__all__ = ["build_parser", "main"]


def build_parser():
    """The ``nh-operators`` argument parser with every subcommand."""
    parser = argparse.ArgumentParser(prog="nh-operators", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    for family in (generate, predict, training, evaluation, export):
        family.register(sub)
    return parser


def main(argv=None):
    """Run ``nh-operators`` with ``argv`` (default: ``sys.argv[1:]``); return the exit code."""
    args = build_parser().parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)
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
