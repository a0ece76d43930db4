"""The orbit's shape in phase, computed: the phase integral inverted on its own rule.

On the orbit q = a + L (1 − cos πs)/2 (L = b − a) the time from a is
τ(s) = ∫_0^s f(σ) dσ with f = (dq/ds) / |p| smooth in s, and the half-phase is
h(s) = τ(s) / T ∈ [0, 1/2]. The composite Gauss–Legendre rule that gives T already
evaluates f at its nodes s_k; its partial sums Σ_{j ≤ k} f_j w_j, divided by T, are
h at the right ends β_k = Σ_{j ≤ k} w_j of the nodes' weight intervals, up to a local
error of the order of the interval squared that does not accumulate (every panel's sum is
the rule's). That table (β_k, h_k), increasing in both, is read backwards: the shape
Q(h) = (1 − cos π s(h))/2 on a uniform grid of h by linear interpolation of s(h), and
P(h) = (T / L) |p| at s(h), |p| = sqrt(2 (E − V)) linear in s between the nodes and zero
at the turning points. This is a classical quadrature solve of the orbit in the sensor
spline; PhaseONet's ``shape="quadrature"`` learns a correction to it.

:func:`shape_table` is the torch version (any device, differentiable in f and T);
:func:`invert_row` the compiled one that :func:`._orbit._quadrature_compiled` calls
per row.
"""

import math

import numba
import numpy as np
import torch

__all__ = ["harmonic_shape", "shape_table"]


def harmonic_shape(grid, dtype=torch.float64, device=None):
    """The harmonic orbit's (Q, P) on ``grid`` nodes of h ∈ [0, 1/2], each (grid,):
    (1 − cos 2πh)/2 and π sin 2πh (Q's derivative in h)."""
    h = torch.linspace(0.0, 0.5, grid, dtype=dtype, device=device)
    return (1 - torch.cos(2 * math.pi * h)) / 2, math.pi * torch.sin(2 * math.pi * h)


def shape_table(f, speed, s, w, T, L, grid):
    """(Q, P) of each row on ``grid`` nodes of the half-phase h ∈ [0, 1/2].

    Args:
        f: (B, K) (dq/ds) / |p| at the rule's nodes.
        speed: (B, K) |p| = sqrt(2 (E − V)) at the nodes.
        s, w: (K,) the rule's nodes (increasing, in (0, 1)) and weights (summing to 1).
        T: (B,) the period, 2 Σ f w on the same rule.
        L: (B,) b − a.
        grid: number of nodes of h.

    Returns:
        Q, P, each (B, grid), in the dtype of f.
    """
    B, K = f.shape
    zero = f.new_zeros(B, 1)
    edges = torch.cat([s.new_zeros(1), torch.cumsum(w, 0)])               # (K + 1,)
    phase = torch.cat([zero, torch.cumsum(f * w, 1) / T[:, None]], 1)      # (B, K + 1)
    h = torch.linspace(0.0, 0.5, grid, dtype=f.dtype, device=f.device).expand(B, -1)
    right = torch.searchsorted(phase.detach().contiguous(), h.contiguous()).clamp_(1, K)
    lo, hi = torch.gather(phase, 1, right - 1), torch.gather(phase, 1, right)
    weight = ((h - lo) / (hi - lo).clamp(min=1e-300)).clamp(0, 1)
    x = torch.lerp(edges[right - 1], edges[right], weight)                # s(h)
    Q = (1 - torch.cos(math.pi * x)) / 2
    ends = s.new_tensor([0.0]), s.new_tensor([1.0])
    nodes = torch.cat([ends[0], s, ends[1]])                              # (K + 2,)
    table = torch.cat([zero, speed, zero], 1)
    j = torch.searchsorted(nodes, x.detach().contiguous()).clamp_(1, K + 1)
    weight = ((x - nodes[j - 1]) / (nodes[j] - nodes[j - 1])).clamp(0, 1)
    P = torch.lerp(torch.gather(table, 1, j - 1), torch.gather(table, 1, j), weight)
    return Q, P * (T / L)[:, None]


@numba.njit(cache=True, nogil=True)
def invert_row(f, speed, s, w, T, L, Q, P):
    """:func:`shape_table` for one row, into Q and P (grid,) (the same arithmetic)."""
    K, grid = f.shape[0], Q.shape[0]
    edges = np.empty(K + 1)
    phase = np.empty(K + 1)
    edges[0], phase[0], acc, total = 0.0, 0.0, 0.0, 0.0
    for k in range(K):
        acc += w[k]
        total += f[k] * w[k]
        edges[k + 1], phase[k + 1] = acc, total / T
    right, node = 1, 0      # walk the table and the nodes once, h and s increasing
    for g in range(grid):
        h = 0.5 * g / (grid - 1)
        while right < K and phase[right] < h:
            right += 1
        lo, hi = phase[right - 1], phase[right]
        weight = min(max((h - lo) / max(hi - lo, 1e-300), 0.0), 1.0)
        x = edges[right - 1] + weight * (edges[right] - edges[right - 1])
        Q[g] = (1 - math.cos(math.pi * x)) / 2
        while node < K and s[node] < x:   # first node at or above x
            node += 1
        left_s = 0.0 if node == 0 else s[node - 1]
        left_v = 0.0 if node == 0 else speed[node - 1]
        right_s = 1.0 if node == K else s[node]
        right_v = 0.0 if node == K else speed[node]
        weight = min(max((x - left_s) / (right_s - left_s), 0.0), 1.0)
        P[g] = (left_v + weight * (right_v - left_v)) * (T / L)
