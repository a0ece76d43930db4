"""PhaseONet: a fast operator that predicts the orbit's shape in phase, not in time.

Released at rest at q = 0 with E = V0, the particle runs to q = 1 and back with period
T[V] (:mod:`.phase_rules`), and the trajectory is even in time and T-periodic:
q(t) = Q(h), p(t) = ±P(h) with the half-phase h = min(u, 1 − u), u = (t / T) mod 1, and
the sign + while u ≤ 1/2. So the network never has to learn a frequency: the period comes
from a quadrature of the sensor spline (a fixed linear map of the sensors, then 1/sqrt and
a weighted sum, in float64), and a branch MLP predicts Q and P on a uniform grid of the
half-phase [0, 1/2] (:mod:`.phase_head`). :class:`PhaseONet` is the rest scene;
:class:`~.state_phaseonet.StatePhaseONet` starts from a state (q0, p0).
:func:`phaseonet` builds either from a config (``build_model("phaseonet", ...)``).
"""

from typing import Any, Literal

import torch

from .._constants import V0
from ._layers import match_default_float
from .phase_head import BasisHeadNet, check_one_dimensional, orbit_harmonics
from .phase_rules import RestQuadrature, period_quadrature
from .phase_start import StartShape, start_shape
from .state_phaseonet import StatePhaseONet

__all__ = ["PhaseONet", "StatePhaseONet", "period_quadrature", "phaseonet"]

Tensor = torch.Tensor

#: Torch multiply-adds per row below which a PhaseONet's CPU inference runs torch on one
#: thread (:attr:`PhaseONet.cpu_torch_threads`). At batch 1,000 on a 2-core CPU with
#: numba on two threads, µs per trajectory, torch on one thread against two
#: (``benchmarks/cost/torch_threads.py``): width 16, depth 1, basis 4, grid 128 (the
#: shipped quadrature networks, 2.8k) 1.74 against 2.48; width 128, depth 2, basis 32,
#: grid 256 (54k) 4.64 against 4.85; width 256, depth 3 (190k) 7.19 against 6.74
#: (torch's threads pay only there).
LIGHT_TORCH_MACS = 100_000


class PhaseONet(BasisHeadNet):
    """Released at rest: a branch MLP over (V, log T) that predicts the half-orbit in a
    basis of the phase.

    The MLP's last layer gives ``basis`` coefficients per output; a trainable basis,
    initialised to the harmonics cos 2πmh (for q) and sin 2π(m+1)h (for p), turns them
    into values on a uniform grid of ``grid`` nodes over h ∈ [0, 1/2], added to the start
    (``shape``) and read off at the asked phases by linear interpolation. Like DeepONet's
    branch and trunk, a learned function of V is combined with a basis in the query
    (here a fixed-period phase instead of a trunk network).

    Cost per trajectory: one (m × nodes) float64 product for the period, an MLP of
    (m + 1)·width + (depth − 1)·width² + width·2·basis multiply-adds, 2·basis·grid for
    the basis, and O(1) per asked time and output. No trunk and no attention:
    predictions at different times are independent (``query_coupled`` False), and any
    t ≥ 0 is answered from the same periodic orbit (the phase error grows like
    t · δT / T).

    Args:
        width: hidden width of the branch MLP (default 128: at 1 thread and batch
            1,000 the MLP then costs about as much as the period and the read-out).
        depth: hidden layers (default 2).
        basis: coefficients per output (default 32).
        grid: nodes of the half-phase grid (default 256, ≥ 2; the linear
            interpolation's error is at most (1/(2·(grid − 1)))²/8 · max abs(Q'')).
        nodes: Gauss–Legendre nodes of the period quadrature (default 64).
        activation: "gelu" (default), "relu", "tanh" or "silu".
        shape: where Q and P start (:mod:`.phase_start`): :class:`HarmonicStart`
            (``"learned"``, default), the MLP learning the whole shape from the harmonic
            orbit (1 − cos 2πh)/2 (P from zero); or :class:`QuadratureStart`
            (``"quadrature"``), the shape computed by inverting the period's own
            Gauss–Legendre rule, the MLP learning a correction that starts at zero.
        n_sensors: length m of V (default 100).
        n_outputs: 2 (q and p; default) or 1 (q only, shape (B, M)).
        query_dim: 1 (the query points are times); anything else is refused.
        query_coupled: False (each time is answered on its own); True is refused.
        regularization: DeepXDE's ``NN.regularizer`` (e.g. ``["l2", 1e-5]``) or None.

    Raises:
        ValueError: for ``query_dim`` other than 1 or ``n_outputs`` other than 1 or 2
            (PhaseONet serves only the 1-D Hamiltonian problem), grid < 2, a
            non-positive basis, depth or width, an unknown activation or shape.

    Input ``(V, t)``: V (B, m) with V0 at both walls and V < V0 inside (the network
    clamps V0 − V at 1e-12; out-of-domain input is the domain check's job); t (M, 1).
    Output (B, M, n_outputs).

    References:
        T.-G. Kim and S. C. Park, "Neural Hamilton: Can A.I. Understand Hamiltonian
        Mechanics?" (2024): the problem, its data and the networks PhaseONet is
        measured against. L. Lu, P. Jin, G. Pang, Z. Zhang and G. E. Karniadakis,
        "Learning nonlinear operators via DeepONet based on the universal approximation
        theorem of operators", Nature Machine Intelligence 3, 218–229 (2021): the
        branch-times-basis form.

    Example:
        >>> net = PhaseONet(width=32, depth=1, basis=8, grid=16)
        >>> V = 8 * (torch.linspace(0, 1, 100) - 0.5) ** 2
        >>> net((V[None], torch.linspace(0, 2, 7)[:, None])).shape
        torch.Size([1, 7, 2])
    """

    def __init__(self, width: int = 128, depth: int = 2, basis: int = 32, grid: int = 256,
                 nodes: int = 64, activation: str = "gelu",
                 shape: "StartShape | Literal['learned', 'quadrature']" = "learned",
                 n_sensors: int = 100, n_outputs: int = 2, query_dim: int = 1,
                 query_coupled: bool = False, regularization: Any = None) -> None:
        check_one_dimensional("PhaseONet", query_dim, n_outputs, (1, 2), query_coupled)
        start = start_shape(shape)
        harmonics, tables = orbit_harmonics(basis, grid, moving=False)
        super().__init__(n_sensors + 1, harmonics[:n_outputs], tables[:n_outputs],
                         width=width, depth=depth, activation=activation,
                         zero_correction=start.zero_correction, n_sensors=n_sensors,
                         regularization=regularization)
        self.start = start
        self.quadrature = RestQuadrature(n_sensors, nodes)
        match_default_float(self)

    @property
    def cpu_torch_threads(self) -> int | None:
        """1 when the torch work per row is light (below :data:`LIGHT_TORCH_MACS`
        multiply-adds: the branch MLP and the basis product), else None (torch's own
        count): :func:`~.inference.batched_forward` then runs torch on one thread on the
        CPU, while the compiled period, shape and read-out keep numba's threads."""
        macs = sum(p.numel() for p in self.branch.parameters()) + self.basis.numel()
        return 1 if macs < LIGHT_TORCH_MACS else None

    def period(self, V: Tensor) -> Tensor:
        """T[V] of the sensor spline, shape (B,), float64."""
        return self.quadrature.period(V)

    def _forward(self, V: Tensor, t: Tensor) -> Tensor:
        T, start = self.start.at_rest(self.quadrature, V, self.grid, self.start_tables())
        x = torch.cat([(V0 - V) / 2, torch.log(T).to(V.dtype)[:, None]], dim=1)
        coeffs = self.branch(x)                                   # (B, k · basis)
        tables = self.shape_tables(coeffs, start)                 # each (B, grid)
        return self.read_orbit(tables, torch.reciprocal(T), t)


def phaseonet(width: int = 128, depth: int = 2, basis: int = 32, grid: int = 256,
              nodes: int = 64, activation: str = "gelu",
              shape: Literal["learned", "quadrature"] = "learned",
              initial_state: bool = False, panels: int | None = None,
              n_sensors: int = 100, n_outputs: int = 2, query_dim: int = 1,
              query_coupled: bool = False,
              regularization: Any = None) -> "PhaseONet | StatePhaseONet":
    """A PhaseONet from config values: the registry's ``"phaseonet"``.

    Args:
        initial_state: False (default): :class:`PhaseONet`, released at rest; True:
            :class:`StatePhaseONet`, V carries (q0, p0) after the sensors.
        panels: the composite rule's panels of a :class:`StatePhaseONet` (default 32;
            only with ``initial_state``).
        width, depth, basis, grid, nodes, activation, shape, n_sensors, n_outputs,
        query_dim, query_coupled, regularization: as in :class:`PhaseONet`.

    Returns:
        The network.

    Raises:
        ValueError: ``panels`` without ``initial_state``, and as the classes.

    Example:
        >>> type(phaseonet(width=8, depth=1, basis=4, grid=8, initial_state=True)).__name__
        'StatePhaseONet'
    """
    common: dict[str, Any] = {
        "width": width, "depth": depth, "basis": basis, "grid": grid, "nodes": nodes,
        "activation": activation, "shape": shape, "n_sensors": n_sensors,
        "n_outputs": n_outputs, "query_dim": query_dim, "query_coupled": query_coupled,
        "regularization": regularization}
    if initial_state:
        rule: dict[str, Any] = {} if panels is None else {"panels": panels}
        return StatePhaseONet(**common, **rule)
    if panels is not None:
        raise ValueError("panels sets the composite rule of a network from a state: it "
                         "needs initial_state=True")
    return PhaseONet(**common)
