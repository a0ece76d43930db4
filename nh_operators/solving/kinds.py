"""The two vocabularies of a calibration: what kind of input a call has, and what kind of
call it is.

The input kind decides the truth an estimate is calibrated against (an exact potential's
own trajectory, or the trajectory of the spline through sensor values) and which
classical cost a network is weighed against. Other parts of the package name the same
thing in their own words (``coerce_potential``'s ``information``: ``"exact V"`` or
``"sensors"``); :meth:`InputKind.of` and :attr:`InputKind.information` translate, here
and nowhere else.
"""

from __future__ import annotations

from enum import Enum
from typing import Any

__all__ = ["CallKind", "InputKind"]


class InputKind(str, Enum):
    """What a call's potential is.

    * ``BSPLINE``: a generator's exact B-spline (:class:`~nh_operators.BoundedPotential`);
    * ``FORMULA``: any other exact potential (a name, an expression, a callable), which
      the classical solver integrates in Python, so it costs more;
    * ``SENSORS``: the 100 sensor values, whose truth is their spline's trajectory.

    Example:
        >>> InputKind.of(None, "sensors"), InputKind.FORMULA.exact
        (<InputKind.SENSORS: 'sensors'>, True)
    """

    BSPLINE = "bspline"
    FORMULA = "formula"
    SENSORS = "sensors"

    @property
    def exact(self) -> bool:
        """Whether the potential is known exactly (its factors are the ``exact`` ones)."""
        return self is not InputKind.SENSORS

    @property
    def information(self) -> str:
        """The solvers' word for it: ``"sensors"`` or ``"exact V"``."""
        return "sensors" if self is InputKind.SENSORS else "exact V"

    @property
    def truth(self) -> str:
        """The key of its factor table in a calibration file: ``"exact"`` or
        ``"sensors"``."""
        return "exact" if self.exact else "sensors"

    @classmethod
    def of(cls, pot: Any, information: str) -> InputKind:
        """The kind of a coerced potential (``information`` as
        :func:`~nh_operators.solvers.coerce_potential` returns it)."""
        from ..potentials import BoundedPotential

        if information == "sensors":
            return cls.SENSORS
        return cls.BSPLINE if isinstance(pot, BoundedPotential) else cls.FORMULA


class CallKind(str, Enum):
    """What kind of call an estimate was made for; each has its own factors.

    * ``PLAIN``: a call whose latest time is past
      :data:`~nh_operators.solving.acceptance.EARLY_HORIZON`;
    * ``EARLY``: one whose latest time is at most that (the estimate can miss there by
      two orders of magnitude, and a factor for them would waste every other call);
    * ``FINE``: a second look on the finer grid of :mod:`~nh_operators.solving.refine`.

    Example:
        >>> CallKind("early") is CallKind.EARLY
        True
    """

    PLAIN = "plain"
    EARLY = "early"
    FINE = "fine"
