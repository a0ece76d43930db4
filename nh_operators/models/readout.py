"""Twice-differentiable read-out of values on a uniform grid: not-a-knot cubic splines.

A network that computes its outputs on a fixed grid (VaRONet's grid decoders, FNO)
reads them off at the asked query points with :class:`GridSpline`: the not-a-knot
cubic spline through the grid values (SciPy's ``CubicSpline`` default), evaluated in
torch with the piecewise cubic polynomials. The value at a point depends only on that
point and the grid values, it is linear in the grid values, and it is C² in the point:
``dde.grad.jacobian`` and ``dde.grad.hessian`` over the query points give the
spline's pointwise first and second derivatives. In d dimensions the read-out is the
tensor product of 1-D splines (:func:`tensor_spline`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

__all__ = ["GridSpline", "as_ranges", "not_a_knot_matrix", "tensor_spline"]


def not_a_knot_matrix(n: int, spacing: float = 1.0) -> np.ndarray:
    """The linear map from values on a uniform grid to the spline's second derivatives.

    Args:
        n: number of grid points (at least 2).
        spacing: distance h between neighbouring points.

    Returns:
        (n, n) float64 array S: the not-a-knot cubic spline through values y (n,) has
        second derivative ``(S @ y)[i]`` at point i. With n = 3 the spline is the
        parabola through the points and with n = 2 the straight line (as SciPy).

    Raises:
        ValueError: for n < 2 or a spacing that is not positive.

    Example:
        >>> S = not_a_knot_matrix(5)
        >>> np.allclose(S @ np.arange(5.0) ** 2, 2.0)
        True
    """
    if n < 2:
        raise ValueError(f"a spline needs at least 2 grid points, got {n}")
    if not spacing > 0:
        raise ValueError(f"the grid spacing must be positive, got {spacing}")
    if n == 2:
        return np.zeros((2, 2))
    h = float(spacing)
    A = np.zeros((n, n))
    R = np.zeros((n, n))
    for i in range(1, n - 1):  # continuity of the first derivative at point i
        A[i, i - 1:i + 2] = h, 4 * h, h
        R[i, i - 1:i + 2] = np.array([6.0, -12.0, 6.0]) / h
    if n == 3:  # one interior knot: the parabola, a constant second derivative
        A[0, :2] = 1.0, -1.0
        A[2, 1:] = 1.0, -1.0
    else:  # not-a-knot: the third derivative is continuous at points 1 and n - 2
        A[0, :3] = 1.0, -2.0, 1.0
        A[n - 1, n - 3:] = 1.0, -2.0, 1.0
    return np.linalg.solve(A, R)


def as_ranges(query_range: Sequence, query_dim: int) -> tuple[tuple[float, float], ...]:
    """Normalise a range argument to one (low, high) pair per query coordinate.

    Args:
        query_range: one pair (low, high), used for every coordinate, or d pairs.
        query_dim: the number d of coordinates.

    Returns:
        d pairs of floats.

    Raises:
        ValueError: for a wrong number of pairs or a pair with low >= high.

    Example:
        >>> as_ranges((0, 2), 2)
        ((0.0, 2.0), (0.0, 2.0))
    """
    pairs = list(query_range)
    if len(pairs) == 2 and all(np.ndim(p) == 0 for p in pairs):
        pairs = [pairs] * query_dim
    if len(pairs) != query_dim or any(np.ndim(p) != 1 or len(p) != 2 for p in pairs):
        raise ValueError(f"query_range must be one (low, high) pair or {query_dim} of them "
                         f"(one per query coordinate), got {query_range!r}")
    out = tuple((float(lo), float(hi)) for lo, hi in pairs)
    for j, (lo, hi) in enumerate(out):
        if not lo < hi:
            raise ValueError(f"query_range of coordinate {j} must have low < high, got "
                             f"({lo:g}, {hi:g})")
    return out


class GridSpline:
    """The not-a-knot cubic spline through values on ``n`` uniform points of [low, high].

    Args:
        low, high: the ends of the grid (low < high).
        n: number of grid points (at least 2).

    Attributes:
        nodes: the grid, ``numpy.linspace(low, high, n)`` (float64).

    Points outside [low, high] (beyond a relative tolerance of 1e-6 of the range)
    raise a ValueError; the spline is not extrapolated.

    Example:
        >>> spline = GridSpline(0.0, 1.0, 6)
        >>> values = torch.linspace(0, 1, 6, dtype=torch.float64) ** 3
        >>> x = torch.tensor([0.25, 0.5], dtype=torch.float64)
        >>> spline(values, x)
        tensor([0.0156, 0.1250], dtype=torch.float64)
    """

    def __init__(self, low: float, high: float, n: int) -> None:
        if not low < high:
            raise ValueError(f"a grid needs low < high, got ({low:g}, {high:g})")
        self.low, self.high, self.n = float(low), float(high), int(n)
        self.nodes = np.linspace(self.low, self.high, self.n)
        self.spacing = (self.high - self.low) / (self.n - 1) if self.n > 1 else 1.0
        self._matrix = not_a_knot_matrix(self.n, self.spacing)
        self._cache: dict = {}

    def matrix(self, like: torch.Tensor) -> torch.Tensor:
        """(n, n) map from grid values to second derivatives, in ``like``'s dtype/device."""
        key = (like.dtype, like.device)
        if key not in self._cache:
            self._cache[key] = torch.as_tensor(self._matrix, dtype=like.dtype,
                                               device=like.device)
        return self._cache[key]

    def check(self, x: torch.Tensor, what: str = "query points") -> None:
        """Raise a ValueError if a point of ``x`` lies outside [low, high]."""
        if x.numel() == 0:
            return
        tol = 1e-6 * (self.high - self.low)
        lo, hi = float(x.detach().min()), float(x.detach().max())
        if lo < self.low - tol or hi > self.high + tol:
            raise ValueError(f"{what} must lie in [{self.low:g}, {self.high:g}]; got "
                             f"values from {lo:g} to {hi:g}")

    def __call__(self, values: torch.Tensor, x: torch.Tensor,
                 pointwise: bool = False) -> torch.Tensor:
        """Evaluate the spline through ``values`` at ``x``.

        Args:
            values: (..., n) grid values along the last axis; with ``pointwise``,
                (..., M, n): one set of grid values per point.
            x: (M,) points in [low, high].
            pointwise: point m reads row m of the next-to-last axis of ``values``.

        Returns:
            (..., M): the spline's values; twice differentiable in x, linear in values.

        Raises:
            ValueError: for points outside [low, high] or a wrong grid axis length.
        """
        if values.shape[-1] != self.n:
            raise ValueError(f"values must have {self.n} grid points on the last axis, got "
                             f"shape {tuple(values.shape)}")
        self.check(x)
        x = x.to(values.dtype)
        s = (x - self.low) / self.spacing
        if self.n == 2:  # a straight line
            k = torch.zeros_like(s, dtype=torch.long)
        else:
            k = s.detach().floor().long().clamp(0, self.n - 2)
        u = s - k.to(s.dtype)
        moments = values @ self.matrix(values).T  # second derivatives at the nodes
        if pointwise:
            rows = torch.arange(x.shape[0], device=x.device)

            def take(a, i):
                return a[..., rows, i]
        else:
            def take(a, i):
                return a[..., i]
        h2 = self.spacing ** 2 / 6.0
        v = 1.0 - u
        return (v * take(values, k) + u * take(values, k + 1)
                + h2 * ((v ** 3 - v) * take(moments, k) + (u ** 3 - u) * take(moments, k + 1)))


def tensor_spline(splines: Sequence[GridSpline], values: torch.Tensor,
                  x: torch.Tensor) -> torch.Tensor:
    """Read d-dimensional grid values at points by tensor-product cubic splines.

    Args:
        splines: d splines, one per axis.
        values: (..., n_1, ..., n_d) values on the tensor grid.
        x: (M, d) points; coordinate j lies in the range of ``splines[j]``.

    Returns:
        (..., M): the tensor-product spline at each point (pointwise: value m depends
        only on x[m] and the grid values), twice differentiable in x.

    Raises:
        ValueError: for a shape mismatch or points outside the grids.

    Example:
        >>> s = GridSpline(0.0, 1.0, 5)
        >>> g = torch.linspace(0, 1, 5, dtype=torch.float64)
        >>> values = g[:, None] ** 2 * g[None, :]  # x² y
        >>> tensor_spline([s, s], values, torch.tensor([[0.3, 0.7]], dtype=torch.float64))
        tensor([0.0630], dtype=torch.float64)
    """
    d = len(splines)
    if x.ndim != 2 or x.shape[1] != d:
        raise ValueError(f"points must have shape (M, {d}), got {tuple(x.shape)}")
    if values.ndim < d:
        raise ValueError(f"values need {d} grid axes, got shape {tuple(values.shape)}")
    # the last axis first, shared by all points; then each earlier axis point by point
    out = splines[-1](values, x[:, -1])  # (..., n_1, ..., n_{d-1}, M)
    for j in range(d - 2, -1, -1):
        out = splines[j](out.transpose(-1, -2), x[:, j], pointwise=True)
    return out
