"""PhaseONet's float64 quadratures: the period at rest, and the orbit through a state.

Released at rest at q = 0 with E = V0, the particle runs to q = 1 and back with period

    T[V] = 2 ∫_0^1 dq / sqrt(2 (V0 − V(q))).

With q = (1 − cos πs)/2 the end-point singularities of 1/sqrt(V0 − V) cancel
(V0 − V ≈ −V'(0) q near the wall at 0, dq/ds ∝ sin πs), and Gauss–Legendre in s converges
fast: T = 2 Σ_k w_k / sqrt(2 (S (V0 − V_sensors))_k), with S the sensor spline's values at
the nodes (a constant matrix: :func:`~nh_operators._sensors.spline_matrix`). From a state
the ends a < b and the phase come from :func:`~.orbit_coordinates.orbit` on a composite
rule. Each network holds its one rule as float64 buffers
(:class:`~.float64_buffers.Float64Buffers`): ``.to(device)`` moves it, casts do not
round it, and the ``state_dict`` does not hold it.
"""

import math

import numba
import numpy as np
import torch

from .._constants import V0
from .._sensors import spline_matrix
from .float64_buffers import Float64Buffers
from .orbit_coordinates import SensorSpline, composite_rule, invert_row, orbit
from .orbit_shape import edge_tables, shape_table

__all__ = ["OrbitQuadrature", "RestQuadrature", "gauss_legendre", "period_quadrature"]


def gauss_legendre(nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre on [0, 1]: nodes s and weights w, each (nodes,), float64; Σ w = 1.

    Example:
        >>> s, w = gauss_legendre(2)
        >>> round(float(s ** 3 @ w), 15)    # exact for degree ≤ 3: ∫ s³ = 1/4
        0.25
    """
    s, w = np.polynomial.legendre.leggauss(nodes)
    return (s + 1) / 2, w / 2


def _rest_rule(n_sensors: int, nodes: int) -> tuple[np.ndarray, ...]:
    """(s, w, Jacobian (π/2) sin πs, S (m, nodes)) of the rest scene's rule."""
    s, w = gauss_legendre(nodes)
    q = (1 - np.cos(np.pi * s)) / 2
    return s, w, (math.pi / 2) * np.sin(np.pi * s), spline_matrix(q, n_sensors).T


def period_quadrature(n_sensors: int = 100, nodes: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """The period T[V] as a linear map followed by a weighted sum of 1/sqrt.

    T = 2 Σ_k w_k / sqrt(2 (S (V0 − V_sensors))_k) (module docstring).

    Args:
        n_sensors: sensor count m (uniform on [0, 1]).
        nodes: Gauss–Legendre nodes (default 64; ``tests/models/test_phaseonet.py``
            checks the period against exact and independent ones).

    Returns:
        (S, w): S of shape (m, nodes) in float64, w of shape (nodes,) with the
        1/2 · (π/2) sin πs Jacobian folded in.

    Example:
        >>> from nh_operators import SENSORS
        >>> S, w = period_quadrature()
        >>> V = 2 - 8 * SENSORS * (1 - SENSORS)             # harmonic, ω = 4: T = π/2
        >>> round(float(2 * w @ (2 * (2 - V) @ S) ** -0.5), 12)
        1.570796326795
    """
    _, w, jacobian, S = _rest_rule(n_sensors, nodes)
    return S, jacobian * w



#: Rows from which :func:`rest_tables` runs on numba's threads (fewer: one thread, no
#: launch cost).
PARALLEL_FROM = 32


@numba.njit(cache=True, nogil=True, inline="always")
def _rest_row(f, s, w, T, ends, cos_e, sin_e, gaps, Q, P, q_out, p_out):
    """One row of :func:`rest_tables`, through the float64 scratch rows Q and P."""
    invert_row(f, s, w, T, ends, cos_e, sin_e, gaps, Q, P)
    for g in range(Q.shape[0]):
        q_out[g] = Q[g]
        p_out[g] = P[g] / T


@numba.njit(cache=True, nogil=True)
def _rest_rows_serial(f, s, w, T, ends, cos_e, sin_e, gaps, q_out, p_out):
    grid = q_out.shape[1]
    Q, P = np.empty(grid), np.empty(grid)
    for r in range(f.shape[0]):
        _rest_row(f[r], s, w, T[r], ends, cos_e, sin_e, gaps, Q, P, q_out[r], p_out[r])


@numba.njit(cache=True, nogil=True, parallel=True)
def _rest_rows_parallel(f, s, w, T, ends, cos_e, sin_e, gaps, q_out, p_out):
    grid = q_out.shape[1]
    for r in numba.prange(f.shape[0]):
        Q, P = np.empty(grid), np.empty(grid)
        _rest_row(f[r], s, w, T[r], ends, cos_e, sin_e, gaps, Q, P, q_out[r], p_out[r])


def rest_tables(f: np.ndarray, s: np.ndarray, w: np.ndarray, T: np.ndarray,
                edges: tuple[np.ndarray, ...], grid: int,
                dtype: np.dtype | type = np.float64) -> tuple[np.ndarray, np.ndarray]:
    """The rest scene's half-orbit tables, compiled: Q and abs(p) = P / T per row.

    Each row is :func:`~.orbit_coordinates.invert_row` in float64, then written in
    ``dtype`` (a float32 network reads its start tables without another pass over them);
    from :data:`PARALLEL_FROM` rows on, the rows are shared among numba's threads, bit
    for bit the same.

    Args:
        f: (B, K) float64 speeds' inverses at the nodes; s, w: (K,) the nodes and
            weights; T: (B,) periods; edges: :func:`~.orbit_shape.edge_tables`.
        grid: nodes of the half-phase.
        dtype: the tables' dtype (float64 or float32).

    Returns:
        (Q, abs(p)), each (B, grid) in ``dtype``.
    """
    rows = f.shape[0]
    Q, P = np.empty((rows, grid), dtype=dtype), np.empty((rows, grid), dtype=dtype)
    kernel = (_rest_rows_parallel if rows >= PARALLEL_FROM and numba.get_num_threads() > 1
              else _rest_rows_serial)
    ends, cos_e, sin_e, gaps = edges
    kernel(f, s, w, T, ends, cos_e, sin_e, gaps, Q, P)
    return Q, P


class RestQuadrature(Float64Buffers):
    """The rest scene's rule: the period of a batch of V, and its computed shape.

    Args:
        n_sensors: sensor count m.
        nodes: Gauss–Legendre nodes (default 64).

    Example:
        >>> x = torch.linspace(0, 1, 100, dtype=torch.float64)
        >>> round(RestQuadrature().period((2 - 8 * x * (1 - x))[None]).item(), 12)
        1.570796326795
    """

    bias: torch.Tensor
    matrix: torch.Tensor
    nodes: torch.Tensor
    weights: torch.Tensor
    jacobian: torch.Tensor
    period_weights: torch.Tensor

    def __init__(self, n_sensors: int = 100, nodes: int = 64) -> None:
        super().__init__()
        s, w, jacobian, S = _rest_rule(n_sensors, nodes)
        # 2 (V0 − V) S = bias − V (2S): one addmm
        self.constant("bias", V0 * 2 * S.sum(0))
        self.constant("matrix", -2 * S)
        self.constant("nodes", s)
        self.constant("weights", w)
        self.constant("jacobian", jacobian)
        self.constant("period_weights", 2 * (jacobian * w))
        # the compiled inversion's tables depend on the rule alone: built once, in float64
        self.edges = edge_tables(np.asarray(s, np.float64), np.asarray(w, np.float64))

    def _squared_speed(self, V: torch.Tensor) -> torch.Tensor:
        """p² = 2 (V0 − V) at the nodes, (B, nodes), clamped at 2e-12."""
        return torch.addmm(self.bias, V.to(torch.float64), self.matrix).clamp_(min=2e-12)

    def period(self, V: torch.Tensor) -> torch.Tensor:
        """T[V] of the sensor spline.

        Args:
            V: (B, m) sensor values (any float dtype).

        Returns:
            (B,) float64.
        """
        return torch.rsqrt_(self._squared_speed(V)) @ self.period_weights

    def rest_shape(self, V: torch.Tensor, grid: int, dtype: torch.dtype = torch.float64
                   ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """The period and the computed half-orbit, the rule read backwards
        (:mod:`.orbit_shape`: a classical solve of the orbit in the sensor spline).

        Args:
            V: (B, m) sensor values.
            grid: nodes of the half-phase h ∈ [0, 1/2].
            dtype: the dtype of the tables (computed in float64, then cast).

        Returns:
            (T (B,) float64, Q (B, grid), abs(p) (B, grid) in ``dtype``): q = Q(h),
            abs(p) at h. Compiled on the CPU when no gradient is asked
            (:func:`rest_tables`); torch formulas otherwise.
        """
        s, w = self.nodes, self.weights
        f = self.jacobian * torch.rsqrt_(self._squared_speed(V))
        T = 2 * (f @ w)
        if V.device.type == "cpu" and not (torch.is_grad_enabled() and V.requires_grad):
            Q, P = rest_tables(f.numpy(), s.numpy(), w.numpy(), T.numpy(), self.edges, grid,
                               torch.empty(0, dtype=dtype).numpy().dtype)
            return T, torch.from_numpy(Q), torch.from_numpy(P)
        Q, P = shape_table(f, s, w, T, grid)
        return T, Q.to(dtype), (P / T[:, None]).to(dtype)


class OrbitQuadrature(Float64Buffers):
    """The rule of the orbit through a state: the sensor spline, the nodes where U = E − V
    is read, and a composite Gauss–Legendre rule for T and the phase.

    Args:
        n_sensors: sensor count m.
        nodes: Gauss–Legendre nodes where U is read (default 64).
        panels: panels of 16 nodes of the composite rule (default 32).

    Example:
        >>> x = torch.linspace(0, 1, 100, dtype=torch.float64)
        >>> state = torch.tensor([0.5]), torch.tensor([1.0])   # E = V(1/2) + 1/2 = 0.5
        >>> o = OrbitQuadrature()((2 - 8 * x * (1 - x))[None], *state)
        >>> round(o["T"].item(), 10)                             # π / 2
        1.5707963268
    """

    nodes: torch.Tensor
    rule_nodes: torch.Tensor
    rule_weights: torch.Tensor

    def __init__(self, n_sensors: int = 100, nodes: int = 64, panels: int = 32) -> None:
        super().__init__()
        self.spline = SensorSpline(n_sensors)
        self.constant("nodes", gauss_legendre(nodes)[0])
        rule_s, rule_w = composite_rule(panels, 16)
        self.constant("rule_nodes", rule_s)
        self.constant("rule_weights", rule_w)

    def forward(self, V: torch.Tensor, q0: torch.Tensor, p0: torch.Tensor,
                shape_grid: int = 0) -> dict[str, torch.Tensor]:
        """The orbit of :func:`~.orbit_coordinates.orbit` (all float64).

        Args:
            V: (B, m) sensor values; q0, p0: (B,) the state.
            shape_grid: with a positive count, also the computed shape Q, P on that many
                nodes of the half-phase.

        Returns:
            dict of a, b, E, T, u0 (B,), U (B, nodes), and with ``shape_grid`` Q and P.
        """
        f64 = torch.float64
        return orbit(self.spline, V.to(f64), q0.to(f64), p0.to(f64), self.nodes,
                     (self.rule_nodes, self.rule_weights), shape_grid=shape_grid)
