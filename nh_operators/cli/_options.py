"""Argument types and the parser of ``nh-operators``: bad options fail up front, in one line.

Every check here runs while the arguments are parsed, before any work starts and before
the library (torch, DeepXDE) is imported, so a mistyped flag costs a fraction of a second.
"""

import argparse
import ast
import math
import os

__all__ = ["Parser", "positive_int", "nonnegative_int", "positive_float", "finite_float",
           "unit_interval", "existing_file", "existing_dir", "figure_file", "key_value",
           "FIGURE_SUFFIXES"]

#: Figure formats matplotlib's Agg and vector backends write, by file suffix.
FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".svgz", ".eps", ".ps", ".jpg", ".jpeg", ".tif",
                   ".tiff", ".webp", ".pgf")


class Parser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors are one line: ``PROG: error: MESSAGE``, exit 2."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _int(text):
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def positive_int(text):
    """An integer ≥ 1."""
    value = _int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {value}")
    return value


def nonnegative_int(text):
    """An integer ≥ 0 (a seed)."""
    value = _int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {value}")
    return value


def finite_float(text):
    """A finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be finite, got {text!r}")
    return value


def positive_float(text):
    """A finite number > 0."""
    value = finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return value


def unit_interval(text):
    """A number in [0, 1)."""
    value = finite_float(text)
    if not 0 <= value < 1:
        raise argparse.ArgumentTypeError(f"must lie in [0, 1), got {text!r}")
    return value


def existing_file(text):
    """A path to a file that exists (not a directory)."""
    if os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"{text!r} is a directory; give a file")
    if not os.path.exists(text):
        raise argparse.ArgumentTypeError(f"no file {text!r}")
    return text


def existing_dir(text):
    """A path to a directory that exists."""
    if not os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"no directory {text!r}")
    return text


def figure_file(text):
    """A figure path whose suffix names a format matplotlib writes, in a writable folder."""
    suffix = os.path.splitext(text)[1].lower()
    if suffix not in FIGURE_SUFFIXES:
        raise argparse.ArgumentTypeError(
            f"cannot write a figure as {suffix or 'a file without a suffix'!r} ({text!r}); use "
            f"one of {', '.join(FIGURE_SUFFIXES)}")
    if os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"{text!r} is a directory; give a file name")
    folder = os.path.dirname(os.path.abspath(text))
    if not os.path.isdir(folder) or not os.access(folder, os.W_OK):
        raise argparse.ArgumentTypeError(f"cannot write to the folder {folder!r}")
    return text


def key_value(text):
    """``KEY=VALUE`` with a non-empty key, as a (key, value) pair; the value is a Python
    literal where it parses as one (``0.1``, ``True``), else the text."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    try:
        return key.strip(), ast.literal_eval(value)
    except (ValueError, SyntaxError):
        return key.strip(), value
