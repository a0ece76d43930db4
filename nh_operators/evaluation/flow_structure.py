"""What a Hamiltonian flow keeps, measured on any map (q0, p0) ↦ (q(t), p(t)).

A Hamiltonian flow is symplectic: its Jacobian J = ∂(q(t), p(t))/∂(q0, p0) satisfies
JᵀΩJ = Ω with Ω = [[0, 1], [−1, 0]]. With one degree of freedom J is 2×2 and
JᵀΩJ = det(J) Ω for every J, so the symplectic defect ‖JᵀΩJ − Ω‖_F is exactly
√2 abs(det J − 1): here symplecticity *is* area preservation, and one number measures both.
The flow is also time-reversible: run to t, reverse the momentum, run t again, reverse it
again, and the start comes back.

The maps are given as ``flow(q0, p0) -> (q, p)`` (arrays (N,) in, (N, M) out), so
classical methods and networks are measured alike; :func:`network_flow` makes one of a
network that reads a starting state, and :func:`network_jacobian` differentiates such a
network exactly, by autograd. :func:`project_energy` puts a prediction back on its
energy.
"""

import numpy as np
import torch

__all__ = ["area_defect", "flow_jacobian", "network_flow", "network_jacobian",
           "project_energy", "reversibility_error", "symplectic_defect"]

_OMEGA = np.array([[0.0, 1.0], [-1.0, 0.0]])


def flow_jacobian(flow, q0, p0, eps=1e-4):
    """Jacobian of a flow by the five-point central difference (error O(eps⁴), rounding
    about 1e-16 / eps): f' ≈ (8 (f(x + ε) − f(x − ε)) − (f(x + 2ε) − f(x − 2ε))) / 12ε.

    Args:
        flow: ``flow(q0, p0) -> (q, p)``: (N,) starting states to (N, M) arrays.
        q0, p0: (N,) states where J is taken (each must stay bounded when moved by 2 eps).
        eps: the step in q0 and in p0.

    Returns:
        (N, M, 2, 2) float64: ``J[..., 0, 1]`` is ∂q(t)/∂p0.

    Example:
        >>> rotate = lambda q, p: (np.stack([q + p], 1), np.stack([p], 1))  # a shear
        >>> J = flow_jacobian(rotate, np.zeros(1), np.zeros(1))
        >>> np.round(J[0, 0], 8).tolist()
        [[1.0, 1.0], [0.0, 1.0]]
    """
    q0, p0 = np.asarray(q0, dtype=np.float64), np.asarray(p0, dtype=np.float64)
    columns = []
    for dq, dp in ((1.0, 0.0), (0.0, 1.0)):
        at = {k: flow(q0 + k * eps * dq, p0 + k * eps * dp) for k in (-2, -1, 1, 2)}
        parts = [(8 * (np.asarray(at[1][i]) - at[-1][i]) - (np.asarray(at[2][i]) - at[-2][i]))
                 / (12 * eps) for i in (0, 1)]
        columns.append(np.stack(parts, axis=-1))
    return np.stack(columns, axis=-1)


def area_defect(J):
    """abs(det J − 1) of Jacobians (..., 2, 2): 0 for an area-preserving (symplectic) map."""
    J = np.asarray(J, dtype=np.float64)
    return np.abs(J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0] - 1.0)


def symplectic_defect(J):
    """‖JᵀΩJ − Ω‖_F of Jacobians (..., 2, 2), computed as written (it equals
    √2 · :func:`area_defect` in one degree of freedom)."""
    J = np.asarray(J, dtype=np.float64)
    form = np.swapaxes(J, -1, -2) @ _OMEGA @ J
    return np.sqrt(np.sum((form - _OMEGA) ** 2, axis=(-2, -1)))


def reversibility_error(flow, q0, p0):
    """How far ``flow`` is from reversible: run it, reverse p, run it again, reverse p.

    Args:
        flow: ``flow(q0, p0) -> (q, p)`` to one time t (M = 1), or several (the last
            is used).
        q0, p0: (N,) starting states.

    Returns:
        (N,) √(((q'' − q0)² + (p'' − p0)²) / 2) (0 for an exact flow).
    """
    q, p = flow(np.asarray(q0, dtype=np.float64), np.asarray(p0, dtype=np.float64))
    q1, p1 = np.asarray(q)[:, -1], -np.asarray(p)[:, -1]
    q2, p2 = flow(q1, p1)
    q2, p2 = np.asarray(q2)[:, -1], -np.asarray(p2)[:, -1]
    return np.sqrt(0.5 * ((q2 - q0) ** 2 + (p2 - p0) ** 2))


def _state_input(net, V, q0, p0):
    if not getattr(net, "initial_state", False):
        raise ValueError("the network does not read a starting state: build it with "
                         "initial_state=True (a map of (q0, p0) needs one)")
    param = next(net.parameters())
    dtype, device = param.dtype, param.device
    V = torch.as_tensor(np.asarray(V), dtype=dtype, device=device)
    state = torch.stack([torch.as_tensor(np.asarray(q0), dtype=dtype, device=device),
                         torch.as_tensor(np.asarray(p0), dtype=dtype, device=device)], 1)
    return V, state


def network_flow(net, V, t):
    """The flow (q0, p0) ↦ (q(t), p(t)) of a network that reads a starting state.

    Args:
        net: a network built with ``initial_state=True`` (in eval mode for a
            deterministic map).
        V: (N, 100) sensor values, one row per state.
        t: (M,) times.

    Returns:
        ``flow(q0, p0) -> (q, p)``, float64 arrays (N, M).

    Raises:
        ValueError: for a network that does not read a state.
    """
    def flow(q0, p0):
        Vt, state = _state_input(net, V, q0, p0)
        times = torch.as_tensor(np.asarray(t), dtype=Vt.dtype, device=Vt.device)[:, None]
        with torch.no_grad():
            y = net((torch.cat([Vt, state], 1), times))
        y = y.double().cpu().numpy()
        return y[..., 0], y[..., 1]
    return flow


def network_jacobian(net, V, q0, p0, t):
    """The exact Jacobian ∂(q(t), p(t))/∂(q0, p0) of a stateful network, by autograd.

    Rows are independent, so each output's gradient over the batch is one backward pass:
    2·M passes in all.

    Args:
        net, V, t: as :func:`network_flow`.
        q0, p0: (N,) states.

    Returns:
        (N, M, 2, 2) float64.

    Raises:
        ValueError: for a network that does not read a state.
    """
    Vt, state = _state_input(net, V, q0, p0)
    state.requires_grad_(True)
    times = torch.as_tensor(np.asarray(t), dtype=Vt.dtype, device=Vt.device)[:, None]
    with torch.enable_grad():
        y = net((torch.cat([Vt, state], 1), times))  # (N, M, 2)
        J = torch.empty(y.shape[0], y.shape[1], 2, 2, dtype=torch.float64)
        for i in range(y.shape[1]):
            for k in range(2):
                (grad,) = torch.autograd.grad(y[:, i, k].sum(), state, retain_graph=True)
                J[:, i, k, :] = grad.double().cpu()
    return J.numpy()


def project_energy(q, p, values_at, energy):
    """Put predicted states back on their energy: keep q (clipped to [0, 1]) and the sign
    of p, and set abs(p) = sqrt(2 (E − V(q))) (0 where V(q) > E).

    A post-processing option for any network's output (the flow conserves
    H = p²/2 + V(q)); what it does to L_tot is measured in
    ``benchmarks/scenes/state_errors.py --project`` and ``rollout.py --project``: it
    helps where q is right and p is not, and hurts where q is wrong (the right energy at
    the wrong place is another orbit's momentum).

    Args:
        q, p: (N, M) predicted positions and momenta.
        values_at: ``values_at(q) -> V`` of each row at (N, M) positions, e.g.
            ``row_source(V, "sensors").values_at`` for sensor values.
        energy: (N,) each row's energy p0²/2 + V(q0).

    Returns:
        (q, p), each (N, M) float64.

    Example:
        >>> V = lambda q: 2 - 8 * q * (1 - q)           # the harmonic well, E = 2 at rest
        >>> q, p = project_energy(np.array([[0.5]]), np.array([[-1.0]]), V, np.array([2.0]))
        >>> float(p[0, 0])                              # −sqrt(2 (2 − V(1/2))) = −2
        -2.0
    """
    q = np.clip(np.asarray(q, dtype=np.float64), 0.0, 1.0)
    p = np.asarray(p, dtype=np.float64)
    gap = np.asarray(energy, dtype=np.float64).reshape(-1, 1) - values_at(q)
    return q, np.where(p < 0, -1.0, 1.0) * np.sqrt(np.maximum(2 * gap, 0.0))
