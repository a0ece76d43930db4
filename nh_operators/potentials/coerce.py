"""What a user may give as a potential, turned into what the solvers take."""

import numpy as np

from .._constants import SENSORS
from .bounded import BoundedPotential, check_bounded
from .expression import parse_potential
from .physical import PHYSICAL_POTENTIALS

__all__ = ["CallablePotential", "as_potential", "check_force"]

#: Where :func:`check_force` probes V': 2,001 points on [0, 1], both walls included.
_FORCE_PROBE = np.linspace(0.0, 1.0, 2001)


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
        return (8 * (self.V(q + h) - self.V(q - h))
                - (self.V(q + 2 * h) - self.V(q - 2 * h))) / (12 * h)


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
        ValueError: for an unknown name, a bad expression, V breaking the bounded
            conditions, a force V' that is not finite somewhere on [0, 1], or sensor
            values of the wrong shape; TypeError for complex values or anything else.

    Example:
        >>> pot, info = as_potential("SHO")
        >>> pot.name, info
        ('sho', 'exact V')
    """
    if isinstance(potential, str):
        key = potential.strip().lower()
        if key in PHYSICAL_POTENTIALS:  # names are case-insensitive: "SHO", "Morse"
            return PHYSICAL_POTENTIALS[key], "exact V"
        pot = parse_potential(potential)
        check_force(pot.dV, name=getattr(pot, "formula", potential))
        return pot, "exact V"
    if isinstance(potential, BoundedPotential):
        if potential.batched:
            raise ValueError(f"one potential is expected here, got a batch of {len(potential)}; "
                             "index it with [i], e.g. pots[0]")
        return potential, "exact V"
    if hasattr(potential, "V") and hasattr(potential, "dV"):
        name = getattr(potential, "name", "V")
        check_bounded(potential.V, name=name)
        check_force(potential.dV, name=name)
        return potential, "exact V"
    if callable(potential):
        pot = CallablePotential(potential, dV)
        check_bounded(pot.V, name=pot.name)
        check_force(pot.dV, name=pot.name)
        return pot, "exact V"
    if np.iscomplexobj(potential):
        raise TypeError("sensor values must be real numbers, got complex ones")
    try:
        values = np.asarray(potential, dtype=np.float64)
    except (TypeError, ValueError):
        values = None
    if values is not None and values.shape == SENSORS.shape:
        return check_bounded(values), "sensors"
    if values is not None and values.ndim == 2 and values.shape[1] == SENSORS.size:
        raise ValueError(f"one potential is expected here, got {values.shape[0]} rows of "
                         "sensor values; index one row, e.g. V[0]")
    if values is not None and values.ndim >= 1 and values.dtype.kind == "f":
        raise ValueError(f"sensor values must have shape ({SENSORS.size},), one value per "
                         f"sensor x_j = j/{SENSORS.size - 1}; got shape {values.shape}")
    raise TypeError(f"cannot use {type(potential).__name__} as a potential: give a name, an "
                    "expression, a callable, a BoundedPotential or the 100 sensor values")


def check_force(dV, name="V"):
    """Refuse, up front, a potential whose force -V' is not finite somewhere on [0, 1].

    A singular potential such as 2 - sqrt(q (1 - q)) has an infinite slope at the walls:
    no solver can step through it, and a solve would return NaN.

    Args:
        dV: a vectorised callable q -> V'(q).
        name: the potential's name, for the message.

    Raises:
        ValueError: naming the first q where V'(q) is infinite or NaN.

    Example:
        >>> check_force(lambda q: 16 * (q - 0.5))
        >>> check_force(lambda q: (2 * q - 1) / (2 * (q * (1 - q)) ** 0.5),
        ...             "2-(q*(1-q))**0.5")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        ValueError: 2-(q*(1-q))**0.5: V'(q) is not finite at q = 0 (V' = -inf): the force ...
    """
    with np.errstate(all="ignore"):
        values = np.broadcast_to(np.asarray(dV(_FORCE_PROBE), dtype=np.float64),
                                 _FORCE_PROBE.shape)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        i = bad[0]
        raise ValueError(f"{name}: V'(q) is not finite at q = {_FORCE_PROBE[i]:.4g} (V' = "
                         f"{values[i]}): the force must be finite on [0, 1]; a potential with "
                         "an infinite slope (a square root at a wall, a pole) cannot be "
                         "integrated")
