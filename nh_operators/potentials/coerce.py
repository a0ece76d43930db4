"""What a user may give as a potential, turned into what the solvers take."""

import numpy as np

from .._constants import SENSORS
from .bounded import BoundedPotential, check_bounded
from .expression import parse_potential
from .physical import PHYSICAL_POTENTIALS

__all__ = ["CallablePotential", "as_potential"]


class CallablePotential:
    """A user's V(q) with its dV(q), or a fourth-order central difference of V (final).

    Args:
        V: a vectorised callable q -> V(q).
        dV: its derivative (default: (8 (V(q+h) - V(q-h)) - (V(q+2h) - V(q-2h))) / 12h).
        h: the difference step.

    Example:
        >>> pot = CallablePotential(lambda q: 8 * (q - 0.5) ** 2)
        >>> round(float(pot.dV(0.25)), 9)
        -4.0
    """

    def __init__(self, V, dV=None, h=1e-3):
        self.name = getattr(V, "__name__", "V")
        self._V, self._dV, self._h = V, dV, h

    def V(self, q):
        return np.asarray(self._V(np.asarray(q, dtype=np.float64)), dtype=np.float64)

    def dV(self, q):
        q = np.asarray(q, dtype=np.float64)
        if self._dV is not None:
            return np.asarray(self._dV(q), dtype=np.float64)
        h = self._h
        return (8 * (self.V(q + h) - self.V(q - h)) - (self.V(q + 2 * h) - self.V(q - 2 * h))) / (12 * h)


def as_potential(potential, dV=None):
    """Turn what a user gives into something the solvers take.

    Args:
        potential: a name of :data:`~nh_operators.PHYSICAL_POTENTIALS`; a text
            expression in q (parsed safely, see :mod:`nh_operators.potentials.expression`); a
            callable V(q); an object with ``V`` and ``dV``; a single
            :class:`BoundedPotential`; or the 100 values at :data:`SENSORS`.
        dV: the derivative of a callable V (default: a fourth-order central difference
            with h = 1e-3, accurate to ~1e-12 relative on smooth potentials).

    Returns:
        (potential object, information): information is ``"exact V"`` or ``"sensors"``
        (then the object is the (100,) array of sensor values).

    Raises:
        ValueError: for an unknown name, a bad expression, or V breaking the bounded
            conditions; TypeError for anything else.
    """
    if isinstance(potential, str):
        if potential in PHYSICAL_POTENTIALS:
            return PHYSICAL_POTENTIALS[potential], "exact V"
        return parse_potential(potential), "exact V"
    if isinstance(potential, BoundedPotential):
        if potential.batched:
            raise ValueError(f"one potential is expected here, got a batch of {len(potential)}; "
                             "index it with [i], e.g. pots[0]")
        return potential, "exact V"
    if hasattr(potential, "V") and hasattr(potential, "dV"):
        check_bounded(potential.V, name=getattr(potential, "name", "V"))
        return potential, "exact V"
    if callable(potential):
        pot = CallablePotential(potential, dV)
        check_bounded(pot.V, name=pot.name)
        return pot, "exact V"
    try:
        values = np.asarray(potential, dtype=np.float64)
    except (TypeError, ValueError):
        values = None
    if values is not None and values.shape == SENSORS.shape:
        return check_bounded(values), "sensors"
    raise TypeError(f"cannot use {type(potential).__name__} as a potential: give a name, an "
                    "expression, a callable, a BoundedPotential or the 100 sensor values")
