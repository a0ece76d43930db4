"""The references of ``operator_problems``, computed without any network.

``cumulative_trapezoid`` (antiderivative), ``poisson_fd`` (−u'' = f, Dirichlet) and
``stokes_velocity``: for Stokes flow in the lid-driven unit cavity, the velocity
(u, v) = (ψ_y, −ψ_x) of the stream function ψ solving the biharmonic equation
Δ²ψ = 0 (Stokes flow, any viscosity), ψ = 0 on the walls, ∂ψ/∂n = 0 on the walls
except the lid y = 1, where ∂ψ/∂y = g(x). Second-order differences on an
(n + 1) × (n + 1) grid: the 13-point biharmonic stencil as the 5-point Laplacian applied
twice, the normal-derivative conditions through one ghost layer. Written for
``operator_problems``; not part of the package.
"""

from __future__ import annotations

import numpy as np

__all__ = ["cumulative_trapezoid", "poisson_fd", "stokes_velocity"]


def cumulative_trapezoid(v: np.ndarray, x: np.ndarray) -> np.ndarray:
    """∫_{x_0}^{x_i} v by the trapezoid rule: v (n, N), x (N,) → (n, N), first column 0.

    Example:
        >>> cumulative_trapezoid(np.array([[1.0, 1.0, 1.0]]), np.array([0.0, 0.5, 1.0]))
        array([[0. , 0.5, 1. ]])
    """
    steps = 0.5 * (v[:, 1:] + v[:, :-1]) * np.diff(x)
    return np.concatenate([np.zeros((len(v), 1)), np.cumsum(steps, axis=1)], axis=1)


def poisson_fd(f: np.ndarray, x: np.ndarray) -> np.ndarray:
    """−u'' = f, u(x_0) = u(x_N) = 0, by second-order differences on a uniform grid.

    Args:
        f: (n, N) right-hand sides on the grid x (N,).

    Returns:
        (n, N) solutions on the grid.

    Example:
        >>> x = np.linspace(0, 1, 2001)
        >>> u = poisson_fd(np.sin(np.pi * x)[None], x)
        >>> bool(abs(u - np.sin(np.pi * x) / np.pi ** 2).max() < 1e-7)
        True
    """
    from scipy.linalg import solve_banded
    n, h = len(x) - 2, x[1] - x[0]
    bands = np.zeros((3, n))
    bands[0, 1:], bands[1], bands[2, :-1] = -1.0, 2.0, -1.0
    inner = solve_banded((1, 1), bands, h * h * f[:, 1:-1].T).T
    return np.pad(inner, ((0, 0), (1, 1)))


def _laplacian(a: np.ndarray, h: float) -> np.ndarray:
    """5-point Laplacian of a (..., P, Q) on its interior: (..., P − 2, Q − 2)."""
    return (a[..., 2:, 1:-1] + a[..., :-2, 1:-1] + a[..., 1:-1, 2:] + a[..., 1:-1, :-2]
            - 4 * a[..., 1:-1, 1:-1]) / (h * h)


def _extended(psi: np.ndarray, g: np.ndarray, n: int) -> np.ndarray:
    """ψ on nodes −1..n + 1 in both axes (index [x, y]) from its interior values
    psi (B, n − 1, n − 1) and the lid velocity g (B, n + 1): zero on the walls, ghosts
    from the normal-derivative conditions."""
    h = 1.0 / n
    e = np.zeros((len(psi), n + 3, n + 3))
    e[:, 2:-2, 2:-2] = psi
    e[:, 0, :] = e[:, 2, :]             # x = 0: ψ_x = 0
    e[:, -1, :] = e[:, -3, :]           # x = 1: ψ_x = 0
    e[:, :, 0] = e[:, :, 2]             # y = 0: ψ_y = 0
    e[:, 1:-1, -1] = e[:, 1:-1, -3] + 2 * h * g   # y = 1: ψ_y = g
    return e


def _residual(psi: np.ndarray, g: np.ndarray, n: int) -> np.ndarray:
    """Δ²ψ at the interior nodes, flattened: (B, (n − 1)²)."""
    h = 1.0 / n
    lap = _laplacian(_extended(psi, g, n), h)    # on nodes 0..n
    return _laplacian(lap, h).reshape(len(psi), -1)


def stokes_velocity(g: np.ndarray, n: int = 32) -> np.ndarray:
    """The cavity's velocity on the (n + 1)² grid nodes for lid velocities g.

    Args:
        g: (B, n + 1) lid velocity at x_i = i / n (zero at the corners for a regular
            flow).
        n: grid intervals per side (n = 32: about 1 % from the converged solution).

    Returns:
        (B, n + 1, n + 1, 2): (u, v) at node [i, j] = (x_i, y_j).

    Raises:
        ValueError: for a g of the wrong length.

    Example:
        >>> x = np.linspace(0, 1, 17)
        >>> uv = stokes_velocity((4 * x * (1 - x))[None], 16)
        >>> uv.shape, float(uv[0, 8, 16, 0])
        ((1, 17, 17, 2), 1.0)
    """
    g = np.asarray(g, dtype=np.float64)
    if g.ndim != 2 or g.shape[1] != n + 1:
        raise ValueError(f"g must have shape (B, {n + 1}), got {g.shape}")
    k = (n - 1) ** 2
    eye = np.eye(k).reshape(k, n - 1, n - 1)
    A = _residual(eye, np.zeros((k, n + 1)), n).T          # column j: unit vector j
    b = _residual(np.zeros((len(g), n - 1, n - 1)), g, n)  # (B, k)
    psi = np.linalg.solve(A, -b.T).T.reshape(len(g), n - 1, n - 1)
    e = _extended(psi, g, n)[:, 1:-1, 1:-1]                # nodes 0..n
    h = 1.0 / n
    uv = np.zeros((len(g), n + 1, n + 1, 2))
    uv[:, 1:-1, 1:-1, 0] = (e[:, 1:-1, 2:] - e[:, 1:-1, :-2]) / (2 * h)
    uv[:, 1:-1, 1:-1, 1] = -(e[:, 2:, 1:-1] - e[:, :-2, 1:-1]) / (2 * h)
    uv[:, :, -1, 0] = g
    return uv
