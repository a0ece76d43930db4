"""The orbit's shape in phase, computed: the phase integral inverted on its own rule.

On the orbit q = a + L (1 − cos πs)/2 (L = b − a) the time from a is
τ(s) = ∫_0^s f(σ) dσ with f = (dq/ds) / |p| smooth in s, and the half-phase is
h(s) = τ(s) / T ∈ [0, 1/2]. The composite Gauss–Legendre rule that gives T already
evaluates f at its nodes s_k; its partial sums Σ_{j ≤ k} f_j w_j, divided by T, are
h at the right ends β_k = Σ_{j ≤ k} w_j of the nodes' weight intervals, up to a local
error of the order of the interval squared that does not accumulate (every panel's sum is
the rule's). That table (β_k, h_k), increasing in both, is read backwards: the shape
Q(h) = (1 − cos π s(h))/2 on a uniform grid of h by linear interpolation of s(h), and
P(h) = (T / L) |p| at s(h) with |p| = (dq/ds) / f = L (π/2) sin(πs) / f: 1/f, smooth
and non-zero at the turning points, is linear in s between the nodes (constant beyond
the first and last), so that |p| vanishes exactly at the turning points and the
harmonic orbit (f constant) comes out exact. This is a classical quadrature solve of the orbit in the sensor
spline; PhaseONet's ``shape="quadrature"`` learns a correction to it (from a state on
the composite rule, at rest on the period's own Gauss–Legendre rule).

:func:`shape_table` is the torch version (any device, differentiable in f and T);
:func:`invert_row` the compiled one that :func:`._orbit._quadrature_compiled` calls
per row, and :func:`invert_rows` for the rest scene.
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


def shape_table(f, s, w, T, grid):
    """(Q, P) of each row on ``grid`` nodes of the half-phase h ∈ [0, 1/2].

    Args:
        f: (B, K) (dq/ds) / |p| at the rule's nodes.
        s, w: (K,) the rule's nodes (increasing, in (0, 1)) and weights (summing to 1).
        T: (B,) the period, 2 Σ f w on the same rule.
        grid: number of nodes of h.

    Returns:
        Q, P, each (B, grid), in the dtype of f: q = a + L Q, |p| = (L / T) P.
    """
    B, K = f.shape
    edges = torch.cat([s.new_zeros(1), torch.cumsum(w, 0)])               # (K + 1,)
    phase = torch.cat([f.new_zeros(B, 1), torch.cumsum(f * w, 1) / T[:, None]], 1)
    h = torch.linspace(0.0, 0.5, grid, dtype=f.dtype, device=f.device).expand(B, -1)
    right = torch.searchsorted(phase.detach().contiguous(), h.contiguous()).clamp_(1, K)
    lo, hi = torch.gather(phase, 1, right - 1), torch.gather(phase, 1, right)
    weight = ((h - lo) / (hi - lo).clamp(min=1e-300)).clamp(0, 1)
    x = torch.lerp(edges[right - 1], edges[right], weight)                # s(h)
    Q = (1 - torch.cos(math.pi * x)) / 2
    inverse = 1 / f
    j = torch.searchsorted(s, x.detach().contiguous()).clamp_(1, K - 1)   # s[j-1] < x ≤ s[j]
    weight = ((x - s[j - 1]) / (s[j] - s[j - 1])).clamp(0, 1)
    g = torch.lerp(torch.gather(inverse, 1, j - 1), torch.gather(inverse, 1, j), weight)
    P = T[:, None] * (math.pi / 2) * torch.sin(math.pi * x) * g
    return Q, P


@numba.njit(cache=True, nogil=True)
def invert_row(f, s, w, T, Q, P):
    """:func:`shape_table` for one row, into Q and P (grid,) (the same arithmetic)."""
    K, grid = f.shape[0], Q.shape[0]
    edges = np.empty(K + 1)
    phase = np.empty(K + 1)
    edges[0], phase[0], acc, total = 0.0, 0.0, 0.0, 0.0
    for k in range(K):
        acc += w[k]
        total += f[k] * w[k]
        edges[k + 1], phase[k + 1] = acc, total / T
    right, node = 1, 1      # walk the table and the nodes once, h and s increasing
    for g in range(grid):
        h = 0.5 * g / (grid - 1)
        while right < K and phase[right] < h:
            right += 1
        lo, hi = phase[right - 1], phase[right]
        weight = min(max((h - lo) / max(hi - lo, 1e-300), 0.0), 1.0)
        x = edges[right - 1] + weight * (edges[right] - edges[right - 1])
        Q[g] = (1 - math.cos(math.pi * x)) / 2
        while node < K - 1 and s[node] < x:   # s[node − 1] < x ≤ s[node], clamped
            node += 1
        weight = min(max((x - s[node - 1]) / (s[node] - s[node - 1]), 0.0), 1.0)
        inverse = 1 / f[node - 1] + weight * (1 / f[node] - 1 / f[node - 1])
        P[g] = T * (math.pi / 2) * math.sin(math.pi * x) * inverse


@numba.njit(cache=True, nogil=True)
def invert_rows(f, s, w, T, grid):
    """:func:`invert_row` for every row: (Q, P), each (B, grid)."""
    rows = f.shape[0]
    Q, P = np.empty((rows, grid)), np.empty((rows, grid))
    for r in range(rows):
        invert_row(f[r], s, w, T[r], Q[r], P[r])
    return Q, P
