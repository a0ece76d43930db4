"""StatePhaseONet: PhaseONet from a starting state (q0, p0), in the orbit's coordinates.

V carries (q0, p0) after the sensors. The orbit through that state
(:mod:`.orbit_coordinates`) has turning points a < b, period T and starting phase u0,
found by quadrature and bisection of the sensor spline in float64. The MLP reads
U = E − V at the quadrature nodes, scaled by its maximum (the orbit's shape in phase
depends on U only up to a scale), and log T; it predicts the half-orbit Q(h), P(h) as
PhaseONet does (:mod:`.phase_head`), and q = a + (b − a) Q(h), p = ± (b − a) / T · P(h)
at the phase u = u0 + t / T.
"""

from typing import Any, Literal

import torch

from ._layers import match_default_float
from .phase_head import BasisHeadNet, check_one_dimensional, orbit_harmonics
from .phase_rules import OrbitQuadrature
from .phase_start import StartShape, start_shape

__all__ = ["StatePhaseONet"]

Tensor = torch.Tensor


class StatePhaseONet(BasisHeadNet):
    """PhaseONet from a starting state: the half-orbit in the coordinates of the orbit
    through (q0, p0).

    Args:
        width: hidden width of the branch MLP (default 128).
        depth: hidden layers (default 2).
        basis: coefficients per output (default 32).
        grid: nodes of the half-phase grid (default 256, ≥ 2).
        nodes: Gauss–Legendre nodes where the MLP reads U = E − V (default 64).
        panels: the period and the phase come from a composite Gauss–Legendre rule of
            ``panels`` × 16 nodes (default 32: an orbit just above a barrier passes its
            top slowly, a peak inside [a, b] that a single rule of 64 nodes resolves
            poorly; ``tests/models/test_phaseonet_states.py`` checks the period 1e-4
            above a barrier against adaptive quadrature).
        activation: "gelu" (default), "relu", "tanh" or "silu".
        shape: where Q and P start (:mod:`.phase_start`): ``"learned"`` (default), the
            harmonic orbit (1 − cos 2πh)/2 and π sin 2πh; or ``"quadrature"``, the shape
            computed by inverting the phase integral on the composite rule, the MLP
            learning a correction that starts at zero.
        n_sensors: the sensor count m (default 100).
        n_outputs: 2 (q and p; the orbit's phase gives the sign of p); anything else is
            refused.
        query_dim: 1 (times); anything else is refused.
        query_coupled: False (each time is answered on its own); True is refused.
        regularization: DeepXDE's ``NN.regularizer`` or None.

    Raises:
        ValueError: for ``query_dim`` ≠ 1 or ``n_outputs`` ≠ 2 (only the 1-D
            Hamiltonian problem), and as :class:`~nh_operators.models.PhaseONet`.

    Input ``(V, t)``: V (B, m + 2), the sensors then q0 and p0; t (M, 1). Output
    (B, M, 2).

    References:
        T.-G. Kim and S. C. Park, "Neural Hamilton: Can A.I. Understand Hamiltonian
        Mechanics?" (2024). L. Lu, P. Jin, G. Pang, Z. Zhang and G. E. Karniadakis,
        "Learning nonlinear operators via DeepONet based on the universal approximation
        theorem of operators", Nature Machine Intelligence 3, 218–229 (2021).

    Example:
        >>> net = StatePhaseONet(width=16, depth=1, basis=4, grid=16)
        >>> V = 8 * (torch.linspace(0, 1, 100) - 0.5) ** 2
        >>> x = torch.cat([V, torch.tensor([0.3, -0.5])])[None]
        >>> net((x, torch.linspace(0, 2, 7)[:, None])).shape
        torch.Size([1, 7, 2])
    """

    initial_state = True

    def __init__(self, width: int = 128, depth: int = 2, basis: int = 32, grid: int = 256,
                 nodes: int = 64, panels: int = 32, activation: str = "gelu",
                 shape: "StartShape | Literal['learned', 'quadrature']" = "learned",
                 n_sensors: int = 100, n_outputs: int = 2, query_dim: int = 1,
                 query_coupled: bool = False, regularization: Any = None) -> None:
        check_one_dimensional("StatePhaseONet", query_dim, n_outputs, (2,), query_coupled)
        start = start_shape(shape)
        harmonics, tables = orbit_harmonics(basis, grid, moving=True)
        super().__init__(nodes + 1, harmonics, tables, width=width, depth=depth,
                         activation=activation, zero_correction=start.zero_correction,
                         n_sensors=n_sensors, regularization=regularization)
        self.start = start
        self.quadrature = OrbitQuadrature(n_sensors, nodes, panels)
        match_default_float(self)

    def state_orbit(self, V: Tensor) -> dict[str, Tensor]:
        """The orbit through each row's state: float64 tensors a, b, E, T, u0 (B,) and
        U (B, nodes) (:func:`~.orbit_coordinates.orbit`), and with the quadrature start
        the computed Q and P (B, grid).

        Args:
            V: (B, m + 2) the sensors, then q0 and p0.
        """
        V = V.to(torch.float64)
        m = self.n_sensors
        return self.quadrature(V[:, :m], V[:, m], V[:, m + 1],
                               shape_grid=self.start.shape_grid(self.grid))

    def _forward(self, V: Tensor, t: Tensor) -> Tensor:
        o = self.state_orbit(V)
        T = o["T"]
        x = torch.cat([o["U"] / o["U"].amax(1, keepdim=True), torch.log(T)[:, None]],
                      dim=1).to(V.dtype)
        coeffs = self.branch(x)                                   # (B, 2 · basis)
        tables = self.shape_tables(coeffs, self.start.from_state(o, self.start_tables()))
        # the phase in float64: u0 + t / T
        Q, P = self.read_orbit(tables, torch.reciprocal(T), t, offset=o["u0"]).unbind(-1)
        dtype = coeffs.dtype
        L = (o["b"] - o["a"]).to(dtype)[:, None]                 # orbit coordinates → q, p
        q = o["a"].to(dtype)[:, None] + L * Q
        return torch.stack([q, P * (L / T.to(dtype)[:, None])], dim=-1)
