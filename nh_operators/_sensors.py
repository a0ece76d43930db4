"""Sensor values from whatever a user holds, and the sensors' not-a-knot cubic spline.

Every function that takes "V at the 100 sensors" (``predict``, a method's ``__call__``,
``integrate_sensors``, ``domain_violations``) also takes what the potential functions
return: a :class:`~nh_operators.BoundedPotential` (one or a batch), a physical or typed
potential, anything with a vectorised ``V(q)``. It is sampled at :data:`SENSORS`.

The not-a-knot cubic spline of the sensor values is the force of the honest baselines
and the potential the networks' quadratures integrate; it is built here only
(:func:`sensor_spline`, :func:`spline_matrix`, :func:`spline_coefficient_map`, and the
compiled :func:`notaknot_params`), without torch.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numba
import numpy as np

from ._constants import SENSORS

if TYPE_CHECKING:
    from scipy.interpolate import CubicSpline

__all__ = ["notaknot_params", "sensor_grid", "sensor_spline", "sensor_values",
           "spline_coefficient_map", "spline_matrix"]


def sensor_values(V: Any, name: str = "V") -> np.ndarray:
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


# ------------------------------------------------ the not-a-knot spline of the sensors
#
# The one place where the sensors' spline is built. The not-a-knot cubic spline of values
# on the uniform grid x_j = j / (m − 1) is a linear map of the values, so it serves in
# three forms: a scipy ``CubicSpline`` of one row or of the identity (whose evaluations
# and coefficients are then the constant matrices of that map, for the networks), and a
# compiled kernel of per-piece coefficients row by row (for the fixed-step solvers,
# ~3 µs a row, where a dense map would cost ~4 m² multiply-adds).


def sensor_grid(n_sensors: int = 100) -> np.ndarray:
    """The uniform sensor grid x_j = j / (m − 1), j = 0 … m − 1: :data:`SENSORS` for m = 100.

    Args:
        n_sensors: the number m of sensors (at least 4: the spline needs four points).

    Returns:
        float64 array (m,).

    Raises:
        ValueError: for fewer than 4 sensors.

    Example:
        >>> bool(np.array_equal(sensor_grid(), SENSORS))
        True
    """
    if n_sensors < 4:
        raise ValueError(f"the not-a-knot sensor spline needs at least 4 sensors, got "
                         f"{n_sensors}")
    return np.linspace(0.0, 1.0, n_sensors)


def sensor_spline(values: np.ndarray, axis: int = 0) -> CubicSpline:
    """The not-a-knot cubic spline of values on the uniform sensor grid, as scipy builds it.

    Args:
        values: (..., m, ...) values at :func:`sensor_grid` (m along ``axis``); the
            identity ``np.eye(m)`` gives the spline's linear map (see
            :func:`spline_matrix`).
        axis: the axis of ``values`` that runs over the sensors.

    Returns:
        ``scipy.interpolate.CubicSpline`` (its ``derivative()`` is −force).

    Example:
        >>> spline = sensor_spline(2 - 8 * SENSORS * (1 - SENSORS))  # exact: a quadratic
        >>> round(float(spline.derivative()(0.25)), 12)
        -4.0
    """
    from scipy.interpolate import CubicSpline  # construction only: a slow import

    values = np.asarray(values, dtype=np.float64)
    return CubicSpline(sensor_grid(values.shape[axis]), values, axis=axis,
                       bc_type="not-a-knot")


def spline_matrix(x: np.ndarray, n_sensors: int = 100) -> np.ndarray:
    """The spline's values at points x as a matrix of the sensor values.

    Args:
        x: (K,) points in [0, 1] (beyond, the end pieces go on).
        n_sensors: the number m of sensors.

    Returns:
        float64 (K, m): row k times the sensor values is the spline at x_k.

    Example:
        >>> S = spline_matrix(np.array([0.0, 0.5]))
        >>> np.round(S @ (SENSORS ** 2), 12).tolist()
        [0.0, 0.25]
    """
    return sensor_spline(np.eye(n_sensors))(np.asarray(x, dtype=np.float64))


def spline_coefficient_map(n_sensors: int = 100) -> np.ndarray:
    """The spline's per-piece polynomial coefficients as a matrix of the sensor values.

    Args:
        n_sensors: the number m of sensors.

    Returns:
        float64 (m, 4 (m − 1)): the sensor values times column 4 i + k is piece i's
        coefficient of (x − x_i)^(3 − k) (scipy's order, x unscaled), on
        x_i ≤ x ≤ x_{i+1}.

    Example:
        >>> c = SENSORS ** 3 @ spline_coefficient_map()      # a cubic is exact
        >>> np.round(c[:4], 12).tolist() == [1.0, 0.0, 0.0, 0.0]   # piece 0: x³
        True
    """
    c = sensor_spline(np.eye(n_sensors)).c   # (4, pieces, m)
    return np.transpose(c, (2, 1, 0)).reshape(n_sensors, -1)


@numba.njit(parallel=True, nogil=True, cache=True)
def notaknot_params(V: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Per-piece coefficients of the not-a-knot cubic spline through each row of V (compiled).

    V holds values on a uniform grid of n points (spacing h = 1/(n-1)); out[i] gets, for
    piece j, a0..a3 of the cubic in s = (q - q_j)/h. Slopes m solve the tridiagonal
    system m_{k-1} + 4 m_k + m_{k+1} = 3 (d_{k-1} + d_k), d = divided differences, with
    the not-a-knot rows eliminated into the second and last-but-one equations
    (2 m_1 + m_2 = (d_0 + 5 d_1)/2, mirrored at the right), which leaves a strictly
    diagonally dominant system for the Thomas algorithm. Each row is computed the same
    way whatever the batch, so results do not depend on the batch size. The same spline
    as :func:`sensor_spline` (to rounding: ``tests/test_sensor_spline.py``).

    Args:
        V: float64 (N, n), C-contiguous, n ≥ 4.
        out: float64 (N, 4 (n − 1)), written in place.

    Example:
        >>> out = np.empty((1, 4 * 99))
        >>> notaknot_params(np.ascontiguousarray(SENSORS[None] ** 2), out)
        >>> np.round(out[0, 4:8] * 99 ** 2, 9).tolist()   # piece 1 of x²: (1 + s)²
        [1.0, 2.0, 1.0, 0.0]
    """
    n = V.shape[1]
    h = 1.0 / (n - 1)
    for i in numba.prange(V.shape[0]):
        y = V[i]
        d = np.empty(n - 1)
        for k in range(n - 1):
            d[k] = (y[k + 1] - y[k]) / h
        m = np.empty(n)
        cp = np.empty(n)
        rhs = np.empty(n)
        # unknowns m_1 .. m_{n-2}; rows k = 1 .. n-2
        for k in range(1, n - 1):
            rhs[k] = 3.0 * (d[k - 1] + d[k])
        rhs[1] = 0.5 * (d[0] + 5.0 * d[1])
        rhs[n - 2] = 0.5 * (d[n - 2] + 5.0 * d[n - 3])
        # forward sweep: row 1 (2, 1), rows 2..n-3 (1, 4, 1), row n-2 (1, 2)
        b = 2.0
        cp[1] = 1.0 / b
        rhs[1] = rhs[1] / b
        for k in range(2, n - 1):
            b = (2.0 if k == n - 2 else 4.0) - cp[k - 1]
            cp[k] = 1.0 / b
            rhs[k] = (rhs[k] - rhs[k - 1]) / b
        m[n - 2] = rhs[n - 2]
        for k in range(n - 3, 0, -1):
            m[k] = rhs[k] - cp[k] * m[k + 1]
        m[0] = 0.5 * (5.0 * d[0] + d[1]) - 2.0 * m[1]
        m[n - 1] = 0.5 * (5.0 * d[n - 2] + d[n - 3]) - 2.0 * m[n - 2]
        for j in range(n - 1):
            delta = y[j + 1] - y[j]
            out[i, 4 * j] = y[j]
            out[i, 4 * j + 1] = h * m[j]
            out[i, 4 * j + 2] = 3.0 * delta - h * (2.0 * m[j] + m[j + 1])
            out[i, 4 * j + 3] = -2.0 * delta + h * (m[j] + m[j + 1])
