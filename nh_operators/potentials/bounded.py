"""Potential objects: the generator's exact B-spline potentials, and the bounded checks.

A *bounded potential* (docs/problem.rst) is a C² function on [0, 1] with V(0) = V(1) = V0 = 2
and V(q) < V0 for 0 < q < 1, so a particle released at rest at q = 0 stays in [0, 1].
"""

import numpy as np

from .._constants import SENSORS, V0
from . import bspline
from ._spline_kernels import bspline_curvature, bspline_force, bspline_value, evaluate

__all__ = ["BoundedPotential", "check_bounded"]


def _evaluate(fn, params, q):
    q = np.asarray(q, dtype=np.float64)
    flat = np.ascontiguousarray(q.reshape(-1))
    out = np.empty((params.shape[0], flat.size))
    evaluate(fn, params, flat, out)
    return out


class BoundedPotential:
    """One or a batch of the generator's potentials, evaluated exactly.

    The potential is the curve (q(λ), V(λ)) of a clamped cubic B-spline through control
    points (q_c, V_c) with q_0 = 0 < q_1 < ... < q_{C-1} = 1. Because the abscissae
    increase, q(λ) is strictly monotone; V at a point q is found by solving q(λ) = q on
    the right polynomial piece with safeguarded Newton iterations (to ~1e-16 in λ), so
    values and slopes are those of the true curve, not of a resampling.

    Args:
        control_q: control abscissae, shape (C,) or (N, C) with 4 ≤ C ≤ 9; a batch may
            pad shorter rows with NaN.
        control_V: control values, same shape.

    Raises:
        ValueError: if the shapes differ, C is out of range, or the abscissae do not
            start at 0, end at 1 and strictly increase.

    Example:
        >>> pot = BoundedPotential([0, 0.3, 0.7, 1], [2, -2, 1, 2])
        >>> float(pot.V(0.0)), float(pot.V(1.0))
        (2.0, 2.0)
    """

    def __init__(self, control_q, control_V):
        cq = np.asarray(control_q, dtype=np.float64)
        cv = np.asarray(control_V, dtype=np.float64)
        if cq.shape != cv.shape or cq.ndim not in (1, 2):
            raise ValueError(
                f"control_q and control_V must have the same shape (C,) or (N, C); got "
                f"{cq.shape} and {cv.shape}"
            )
        self._single = cq.ndim == 1
        cq2 = np.atleast_2d(cq)
        cv2 = np.atleast_2d(cv)
        if not 4 <= cq2.shape[1] <= bspline.MAX_CONTROL:
            raise ValueError(f"need 4 to {bspline.MAX_CONTROL} control points, got {cq2.shape[1]}")
        pad = bspline.MAX_CONTROL - cq2.shape[1]
        cq2 = np.pad(cq2, ((0, 0), (0, pad)), constant_values=np.nan)
        cv2 = np.pad(cv2, ((0, 0), (0, pad)), constant_values=np.nan)
        _check_controls(cq2, cv2)
        self.control_q = cq2
        self.control_V = cv2
        self.params = bspline.pack(cq2, cv2)

    def __len__(self):
        if self._single:
            raise TypeError("a single BoundedPotential has no len()")
        return self.params.shape[0]

    def __getitem__(self, index):
        """The index-th potential of a batch (a slice or index array gives a batch)."""
        cq = self.control_q[index]
        cv = self.control_V[index]
        if cq.ndim == 1:
            n = int(np.sum(np.isfinite(cq)))
            return BoundedPotential(cq[:n], cv[:n])
        return BoundedPotential(cq, cv)

    @property
    def batched(self):
        """True when this object holds a batch (results get a leading N axis)."""
        return not self._single

    def _shape(self, out, q):
        shape = np.shape(q)
        return out.reshape(shape) if self._single else out.reshape((-1,) + shape)

    def V(self, q):
        """V at points q (any shape); a batch returns shape (N,) + q.shape."""
        return self._shape(_evaluate(bspline_value, self.params, q), q)

    def dV(self, q):
        """dV/dq at points q, exact for the curve."""
        return self._shape(-_evaluate(bspline_force, self.params, q), q)

    def d2V(self, q):
        """d²V/dq² at points q (continuous: the potentials are C²)."""
        return self._shape(_evaluate(bspline_curvature, self.params, q), q)

    def __repr__(self):
        n = "1" if self._single else str(self.params.shape[0])
        return f"BoundedPotential(n={n})"


def _check_controls(cq, cv):
    for row, (q, v) in enumerate(zip(cq, cv, strict=True)):
        n = int(np.sum(np.isfinite(q)))
        where = "" if cq.shape[0] == 1 else f" (potential {row})"
        if n < 4 or not np.all(np.isfinite(q[:n])) or not np.all(np.isfinite(v[:n])):
            raise ValueError(f"control points must be finite, at least 4 of them{where}")
        if q[0] != 0.0 or q[n - 1] != 1.0 or np.any(np.diff(q[:n]) <= 0):
            raise ValueError(
                f"control abscissae must start at 0, end at 1 and strictly increase{where}: "
                f"{q[:n].tolist()}"
            )


def check_bounded(V, *, atol=1e-8, n_check=1001, name="V"):
    """Check the bounded-potential conditions and return the sensor values.

    Args:
        V: a callable V(q) (vectorised over a numpy array), or values at
            :data:`SENSORS`: shape (100,) or (N, 100).
        atol: tolerance on V(0) = V(1) = V0.
        n_check: number of points on [0, 1] at which a callable is checked.
        name: how the potential is called in error messages.

    Returns:
        float64 array of V at :data:`SENSORS`, shape (100,) or (N, 100).

    Raises:
        ValueError: naming the first condition that fails and where: wrong length,
            non-finite values, V(0) or V(1) different from V0 = 2, or V ≥ V0 inside.

    Example:
        >>> check_bounded(lambda q: 8 * (q - 0.5) ** 2).shape
        (100,)
    """
    if callable(V):
        grid = np.union1d(np.linspace(0.0, 1.0, n_check), SENSORS)
        with np.errstate(all="ignore"):
            values = np.broadcast_to(np.asarray(V(grid), dtype=np.float64), grid.shape)
        _check_rows(values[None, :], grid, atol, name)
        return values[np.searchsorted(grid, SENSORS)].copy()
    values = np.asarray(V, dtype=np.float64)
    if values.ndim not in (1, 2) or values.shape[-1] != SENSORS.size:
        raise ValueError(
            f"{name} must hold the values at the {SENSORS.size} SENSORS, shape (100,) or "
            f"(N, 100); got shape {values.shape}"
        )
    _check_rows(np.atleast_2d(values), SENSORS, atol, name)
    return values


def _check_rows(values, grid, atol, name):
    # all rows at once, in few array operations when every row passes (the usual case)
    if (np.isfinite(values).all() and (values[:, 1:-1] < V0).all()
            and (np.abs(values[:, ::values.shape[1] - 1] - V0) <= atol).all()):
        return
    # the first failing row then gets its message
    with np.errstate(invalid="ignore"):
        failing = (~np.isfinite(values).all(axis=1)
                   | (np.abs(values[:, 0] - V0) > atol) | (np.abs(values[:, -1] - V0) > atol)
                   | (values[:, 1:-1] >= V0).any(axis=1))
    if not failing.any():
        return
    row = int(np.argmax(failing))
    v = values[row]
    label = name if values.shape[0] == 1 else f"{name}[{row}]"
    bad = np.flatnonzero(~np.isfinite(v))
    if bad.size:
        raise ValueError(f"{label} is not finite at q = {grid[bad[0]]:.6g} ({v[bad[0]]})")
    for end, value in ((0, v[0]), (1, v[-1])):
        if abs(value - V0) > atol:
            raise ValueError(
                f"{label}({end}) = {value:.10g}, but a bounded potential needs "
                f"V(0) = V(1) = V0 = {V0:g} (within {atol:g})"
            )
    i = int(np.flatnonzero(v[1:-1] >= V0)[0]) + 1
    raise ValueError(
        f"{label} ≥ V0 = {V0:g} inside (0, 1): {label}({grid[i]:.6g}) = {v[i]:.10g}; "
        "a bounded potential needs V < V0 for 0 < q < 1"
    )
