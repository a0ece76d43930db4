"""Sensor values from whatever a user holds: an array, or a potential object.

Every function that takes "V at the 100 sensors" (``predict``, a method's ``__call__``,
``integrate_sensors``, ``domain_violations``) also takes what the potential functions
return: a :class:`~nh_operators.BoundedPotential` (one or a batch), a physical or typed
potential, anything with a vectorised ``V(q)``. It is sampled at :data:`SENSORS`.
"""

import numpy as np

from ._constants import SENSORS

__all__ = ["sensor_values"]


def sensor_values(V, name="V"):
    """``V`` as a float64 array of sensor values, (100,) or (N, 100).

    Args:
        V: array-like of sensor values, or an object with a vectorised ``V(q)`` method
            (sampled at :data:`SENSORS`; a batch gives one row per potential).
        name: how error messages call it.

    Returns:
        float64 ndarray; its shape is checked by the caller.

    Raises:
        TypeError: for complex values, or an object that is neither numbers nor a
            potential.

    Example:
        >>> import nh_operators as nh
        >>> sensor_values(nh.PHYSICAL_POTENTIALS["sho"]).shape
        (100,)
    """
    if not isinstance(V, np.ndarray) and callable(getattr(V, "V", None)):
        V = V.V(SENSORS)
    if np.iscomplexobj(V):
        raise TypeError(f"{name} must be real sensor values, got complex numbers")
    try:
        return np.array(V, dtype=np.float64)  # a copy: read-only inputs (HDF5, views) are fine
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name} must be sensor values (an array of shape (100,) or "
                        f"(N, 100)) or a potential with a V(q) method, got "
                        f"{type(V).__name__}: {err}") from None
