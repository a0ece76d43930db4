"""An error about one row of a batch, which says the row it is about.

A solver given N rows (potentials, states, horizons) raises :class:`RowError` with the
index ``row`` of the bad one, and the message starts with ``"row {row}: "``; given a
single row it raises the same error with ``row=None`` and no prefix. A caller that passed
only some rows of a larger call (a chunk, the rows no network answered) names the row
of the whole call with :meth:`RowError.renumbered`.

Why: the row is known where the error is raised. Carrying it as a number lets every
caller renumber it without reading the message back, and keeps the message a user sees
the same whichever layer raised it.
"""

from __future__ import annotations

import functools
from typing import Any, TypeVar

__all__ = ["RowError", "about_row"]

_Error = TypeVar("_Error", bound="RowError")


class RowError(ValueError):
    """A bad row of a batch: ``row`` is its index (None for a single row), ``message``
    the text after the ``"row {row}: "`` that ``str(err)`` starts with.

    Subclasses (:class:`~nh_operators.solvers.periodic.PeriodError`) say what went wrong;
    every one is a ``ValueError``.

    Args:
        message: what is wrong with the row.
        row: the row's index in the batch, or None when the solver was given one row.

    Example:
        >>> err = RowError("its energy exceeds V0", row=3)
        >>> err.row, str(err)
        (3, 'row 3: its energy exceeds V0')
        >>> str(err.renumbered(40))
        'row 40: its energy exceeds V0'
    """

    def __init__(self, message: str, *, row: int | None = None) -> None:
        super().__init__(message if row is None else f"row {row}: {message}")
        self.message = message
        self.row = row

    def renumbered(self: _Error, row: int) -> _Error:
        """The same error (same class, same message) about row ``row``.

        Args:
            row: the row's index in the caller's batch.

        Returns:
            a new error of this class; ``self`` is left as it is.
        """
        return type(self)(self.message, row=row)

    def __reduce__(self) -> tuple[Any, ...]:
        # the row is a keyword: rebuild from (message, row), not from str(self)
        return functools.partial(type(self), row=self.row), (self.message,)


def about_row(err: ValueError, row: int) -> RowError:
    """``err`` as an error about row ``row`` of the caller's batch.

    Args:
        err: an error a solver raised about one row (a :class:`RowError`, whose class is
            kept, or a plain ``ValueError``, whose text becomes the message).
        row: the row's index in the caller's batch.

    Returns:
        a :class:`RowError` (or the subclass of ``err``) that names ``row``.
    """
    if isinstance(err, RowError):
        return err.renumbered(row)
    return RowError(str(err), row=row)
