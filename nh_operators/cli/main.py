"""Command line: ``nh-operators generate | demo | train | tune | evaluate | benchmark |
export | calibrate | predict``.

Thin: parse the arguments, then call the library. Each command family lives in its own
module with a ``register(sub)`` that adds its subcommands.
"""

import argparse
import sys

from . import demo, evaluation, export, generate, predict, training
from ._options import Parser

__all__ = ["build_parser", "main", "DESCRIPTION", "EPILOG"]

#: What ``nh-operators --help`` says before the list of commands (plain text, for users).
DESCRIPTION = """\
Trajectories of a particle in a 1-D potential V(q) on [0, 1], from neural operators
(Neural Hamilton's networks and PhaseONet, shipped trained) or from classical solvers,
and the datasets, training and measurements behind them. New here? Run "demo" (every
method on five physical potentials), then "predict" with a potential of your own.
"""

#: What ``nh-operators --help`` says after the list of commands.
EPILOG = """\
example:
  nh-operators predict --potential "8*(q-0.5)**2" --times 0.5 1 1.5 --tol 1e-8

Each command explains its options: nh-operators COMMAND --help
"""


def build_parser() -> argparse.ArgumentParser:
    """The ``nh-operators`` argument parser with every subcommand.

    Returns:
        the parser; ``parse_args`` sets ``run`` (the command's function) on the result.

    Example:
        >>> build_parser().parse_args(["demo", "--out", "d"]).out
        'd'
    """
    parser = Parser(prog="nh-operators", description=DESCRIPTION, epilog=EPILOG,
                    formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                title="commands")
    for family in (generate, demo, predict, training, evaluation, export):
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
