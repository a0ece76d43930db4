"""The pieces of physics-informed training on Hamilton's equations, in torch.

What: a potential's sensors as a differentiable cubic spline (V and V' at predicted
positions q), the starting state as a hard constraint (an output transform), and the
pointwise time derivative of a whole batch of predictions in two autograd passes.

The math: for H = p²/2 + V(q) the residuals are r_q = dq/dt − p and
r_p = dp/dt + V'(q). With the output transform q(t) = q0 + t · y_q(t),
p(t) = p0 + t · y_p(t), the starting state holds exactly for any network output y.

Why a two-pass derivative: DeepXDE's query points (M, d) are shared by the B rows of a
batch, so the gradient of the outputs with respect to them sums over the rows.
For a pointwise network (``query_coupled = False``) the Jacobian of y[b, m] with respect
to t[m'] is zero for m' ≠ m, so the Jacobian-vector product J · 1 is the pointwise
derivative of every row at once; it is computed as the derivative of the vector-Jacobian
product uᵀJ with respect to u (the "double-vjp" trick), which needs only reverse mode.
DeepXDE's own ``PDEOperatorCartesianProd`` instead loops over the rows, one autograd
pass each.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch

from ..models.readout import not_a_knot_matrix

__all__ = ["SensorSpline", "state_transform", "time_derivative"]


class SensorSpline:
    """The not-a-knot cubic spline of sensor values on uniform knots, in torch.

    The spline is linear in the values: its second derivatives at the knots are S · V for
    the (m × m) map S of :func:`~nh_operators.models.readout.not_a_knot_matrix` (the one
    the networks' read-outs use). A batch of potentials is then splined by one matrix
    product, and evaluation at predicted positions is one cubic piece per point,
    differentiable in q (the gradient reaches the network). Outside the knots the end
    pieces are extended.

    Args:
        knots: (m,) uniformly spaced, increasing knots, m ≥ 4 (e.g.
            :data:`~nh_operators.SENSORS`).

    Raises:
        ValueError: for fewer than 4 knots or non-uniform knots.

    Example:
        >>> import torch
        >>> x = np.linspace(0, 1, 11)
        >>> spline = SensorSpline(x)
        >>> V = torch.tensor(np.stack([x**3, 2 - x]))
        >>> v, dv = spline(V, torch.tensor([[0.55], [0.3]], dtype=torch.float64))
        >>> [round(float(a), 6) for a in v[:, 0]], [round(float(a), 6) for a in dv[:, 0]]
        ([0.166375, 1.7], [0.9075, -1.0])
    """

    def __init__(self, knots: np.ndarray) -> None:
        knots = np.asarray(knots, dtype=np.float64)
        if knots.ndim != 1 or knots.size < 4:
            raise ValueError(f"a not-a-knot spline needs at least 4 knots, got shape "
                             f"{knots.shape}")
        h = np.diff(knots)
        if h[0] <= 0 or not np.allclose(h, h[0], rtol=1e-9, atol=0):
            raise ValueError("knots must be uniformly spaced and increasing")
        self.x0 = float(knots[0])
        self.h = float(h[0])
        self.m = knots.size
        self.moments = torch.as_tensor(not_a_knot_matrix(self.m, self.h))  # V'' = S V

    def __call__(self, V: torch.Tensor, q: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The splines of the rows of V, and their derivatives, at positions q.

        Args:
            V: (B, m) values at the knots.
            q: (B, M) positions (computed in V's dtype).

        Returns:
            (V(q), V'(q)), each (B, M).

        Raises:
            ValueError: when V is not (B, m) or q not (B, M).
        """
        if V.ndim != 2 or V.shape[1] != self.m or q.ndim != 2 or q.shape[0] != V.shape[0]:
            raise ValueError(f"V must be (B, {self.m}) and q (B, M), got {tuple(V.shape)} "
                             f"and {tuple(q.shape)}")
        q = q.to(V.dtype)
        second = V @ self.moments.to(device=V.device, dtype=V.dtype).T  # (B, m)
        piece = torch.floor((q.detach() - self.x0) / self.h).long().clamp(0, self.m - 2)
        y0, y1 = V.gather(1, piece), V.gather(1, piece + 1)
        m0, m1 = second.gather(1, piece), second.gather(1, piece + 1)
        h = self.h
        u = (q - self.x0) / h - piece.to(q.dtype)  # position in the piece, 0 to 1 inside
        v = 1 - u
        value = v * y0 + u * y1 + h**2 / 6 * ((v**3 - v) * m0 + (u**3 - u) * m1)
        slope = (y1 - y0) / h + h / 6 * ((1 - 3 * v**2) * m0 + (3 * u**2 - 1) * m1)
        return value, slope


def state_transform(n_sensors: int, initial_state: bool = False
                    ) -> Callable[[tuple[torch.Tensor, torch.Tensor], torch.Tensor],
                                  torch.Tensor]:
    """A DeepXDE output transform that makes the starting state exact.

    q(t) = q0 + t · y_q and p(t) = p0 + t · y_p, with (q0, p0) = (0, 0) (release at rest,
    the paper's scene) or read from the branch input after the sensors.

    Args:
        n_sensors: m, the number of sensor values in the branch input.
        initial_state: whether the branch input is (B, m + 2) with (q0, p0) last.

    Returns:
        ``f((V, t), y) -> y'`` for ``net.apply_output_transform``; t is (M, 1), y (B, M, 2).

    Example:
        >>> f = state_transform(3, initial_state=True)
        >>> V = torch.tensor([[0.0, 0.0, 0.0, 0.25, -1.0]])
        >>> f((V, torch.tensor([[0.0], [1.0]])), torch.ones(1, 2, 2))[0].tolist()
        [[0.25, -1.0], [1.25, 0.0]]
    """
    def transform(inputs: tuple[torch.Tensor, torch.Tensor], y: torch.Tensor) -> torch.Tensor:
        V, t = inputs
        if y.ndim != 3 or y.shape[-1] != 2:
            raise ValueError(f"the state transform needs outputs (B, M, 2), got {tuple(y.shape)}")
        y = t[None, :, :1].to(y.dtype) * y
        if initial_state:
            state = V[:, n_sensors:n_sensors + 2].to(y.dtype)
            y = y + state[:, None, :]
        return y

    return transform


def time_derivative(y: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """dy[b, m, k]/dt[m] of a pointwise network, for all rows in two autograd passes.

    Args:
        y: (B, M, k) or (B, M) outputs computed from t, with a graph to t.
        t: (M, 1) query times, ``requires_grad`` True.

    Returns:
        Tensor of y's shape, with a graph (so a loss on it trains the network).

    Raises:
        ValueError: when t does not require grad.

    Example:
        >>> t = torch.tensor([[0.0], [0.5], [1.0]], requires_grad=True)
        >>> y = torch.stack([t[:, 0] ** 2, 3 * t[:, 0]])  # two rows, (2, 3)
        >>> time_derivative(y, t).tolist()
        [[0.0, 1.0, 2.0], [3.0, 3.0, 3.0]]
    """
    if not t.requires_grad:
        raise ValueError("the query times must require grad (DeepXDE's dde.Model sets it)")
    u = torch.ones_like(y, requires_grad=True)
    (g,) = torch.autograd.grad(y, t, grad_outputs=u, create_graph=True)
    (dy,) = torch.autograd.grad(g, u, grad_outputs=torch.ones_like(g), create_graph=True)
    return dy
