"""Errors that name the row of a :func:`~nh_operators.solve_many` call they are about."""

from __future__ import annotations

import re

import numpy as np

__all__ = ["RowError", "named_row", "row_error"]


class RowError(ValueError):
    """A bad row of a :func:`solve_many` call: ``row`` is its index in the call, and the
    message starts with ``"row {row}: "``.

    Example:
        >>> err = RowError(3, "its energy exceeds V0")
        >>> err.row, str(err)
        (3, 'row 3: its energy exceeds V0')
    """

    def __init__(self, row: int, message: str) -> None:
        super().__init__(f"row {row}: {message}")
        self.row = row


def row_error(err: ValueError, row: int, message: str) -> ValueError:
    """``err`` about row ``row`` of the call: a :class:`RowError`, or for a subclass of
    ValueError (``PeriodError``) the same class with the row named."""
    if type(err) is ValueError:
        return RowError(row, message)
    return type(err)(f"row {row}: {message}")


def named_row(err: ValueError, rows: np.ndarray) -> ValueError:
    """A solver's error about "row k" of the rows ``rows`` it was given, about row
    ``rows[k]`` of the call (a :class:`RowError`); ``err`` itself if it names no row."""
    found = re.match(r"row (\d+): (.*)", str(err), re.DOTALL)
    if found is None:
        return err
    return row_error(err, int(rows[int(found.group(1))]), found.group(2))
