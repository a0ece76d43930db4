"""The ``nh-operators`` command line (thin: parse, then call the library)."""

from .main import build_parser, main

__all__ = ["build_parser", "main"]
