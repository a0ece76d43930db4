"""The orbit's shape in phase, computed: the phase integral inverted on its own rule.

On the orbit q = a + L (1 − cos πs)/2 (L = b − a) the time from a is
τ(s) = ∫_0^s f(σ) dσ with f = (dq/ds) / |p| smooth in s, and the half-phase is
h(s) = τ(s) / T ∈ [0, 1/2]. The Gauss–Legendre rule that gives T already evaluates f at
its nodes s_k; its partial sums Σ_{j ≤ k} f_j w_j, divided by T, are h at the right ends
β_k = Σ_{j ≤ k} w_j of the nodes' weight intervals, up to a local error of the order of
the interval squared that does not accumulate (every panel's sum is the rule's). That
table, increasing in h, is read backwards on a uniform grid of h: between two ends s is
linear in h, Q = (1 − cos πs)/2, and P = (T / L) |p| with |p| = (dq/ds) / f =
L (π/2) sin(πs) / f, where 1/f (smooth and non-zero at the turning points) is linear in
s between the nodes (constant beyond the first and last). So |p| vanishes exactly at the
turning points, and the harmonic orbit (f constant, s linear in h) comes out exact. What
depends only on the rule (the ends, cos and sin there, where each end falls between the
nodes) is computed once per rule (:func:`edge_tables`); the compiled rows take cos and sin
of πs from the ends' values by the angle-addition formulas with a short series in the
small angle, so a row costs a cumulative sum and one walk over the grid and the nodes.
This is a classical quadrature solve of the orbit in the sensor spline; PhaseONet's
quadrature start (:class:`~nh_operators.models.phase_start.QuadratureStart`) learns a
correction to it (from a state on the composite rule, at rest on the period's own
Gauss–Legendre rule).

:func:`shape_table` is the torch version (any device, differentiable in f and T);
:func:`.orbit_coordinates.invert_row` the compiled one (in the module of the compiled
quadrature that calls it: numba's cache sees changes to a kernel's own file only).
"""

import functools
import math

import numpy as np
import torch

__all__ = ["edge_tables", "harmonic_shape", "shape_table"]


def harmonic_shape(grid: int, dtype: torch.dtype = torch.float64,
                   device: torch.device | str | None = None) -> tuple[torch.Tensor, torch.Tensor]:
    """The harmonic orbit's (Q, P) on ``grid`` nodes of h ∈ [0, 1/2], each (grid,):
    (1 − cos 2πh)/2 and π sin 2πh (Q's derivative in h).

    Example:
        >>> Q, P = harmonic_shape(3)
        >>> [round(v, 12) for v in Q.tolist()]
        [0.0, 0.5, 1.0]
    """
    h = torch.linspace(0.0, 0.5, grid, dtype=dtype, device=device)
    return (1 - torch.cos(2 * math.pi * h)) / 2, math.pi * torch.sin(2 * math.pi * h)


def edge_tables(s: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, ...]:
    """A rule's ends β (K + 1,: 0, then the cumulative weights), cos(πβ), sin(πβ), and
    1 / (s_k − s_{k−1}) (K,; entry 0 unused), float64 numpy.

    Args:
        s, w: (K,) the rule's nodes (increasing, in (0, 1)) and weights (summing to 1).
    """
    return _edge_tables(tuple(np.asarray(s, dtype=np.float64)),
                        tuple(np.asarray(w, dtype=np.float64)))


@functools.lru_cache(maxsize=16)
def _edge_tables(s, w):
    ends = np.concatenate([[0.0], np.cumsum(w)])
    gaps = np.concatenate([[0.0], 1 / np.diff(s)])
    return ends, np.cos(np.pi * ends), np.sin(np.pi * ends), gaps


def shape_table(f: torch.Tensor, s: torch.Tensor, w: torch.Tensor, T: torch.Tensor,
                grid: int) -> tuple[torch.Tensor, torch.Tensor]:
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
    ends = torch.as_tensor(edge_tables(s.cpu().numpy(), w.cpu().numpy())[0], device=f.device)
    phase = torch.cat([f.new_zeros(B, 1), torch.cumsum(f * w, 1) / T[:, None]], 1)
    h = torch.linspace(0.0, 0.5, grid, dtype=f.dtype, device=f.device).expand(B, -1)
    right = torch.searchsorted(phase.detach().contiguous(), h.contiguous()).clamp_(1, K)
    lo, hi = torch.gather(phase, 1, right - 1), torch.gather(phase, 1, right)
    x = ((h - lo) / (hi - lo).clamp(min=1e-300)).clamp(0, 1)
    at = torch.lerp(ends[right - 1], ends[right], x)                      # s(h)
    Q = (1 - torch.cos(math.pi * at)) / 2
    inverse = 1 / f
    j = torch.searchsorted(s, at.detach().contiguous()).clamp_(1, K - 1)
    y = ((at - s[j - 1]) / (s[j] - s[j - 1])).clamp(0, 1)
    inverse = torch.lerp(torch.gather(inverse, 1, j - 1), torch.gather(inverse, 1, j), y)
    P = T[:, None] * (math.pi / 2) * torch.sin(math.pi * at) * inverse
    return Q, P
