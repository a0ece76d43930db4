"""The orbit through a state (q0, p0) in the sensor spline of V, in float64.

A bounded orbit of energy E = p0²/2 + V(q0) runs between the turning points a < q0 < b
of the connected part of {V < E} that holds q0, with period
T = 2 ∫_a^b dq / sqrt(2 (E − V)); the state sits at the phase u0 = τ0 / T of that orbit
(τ0 the time from a to q0; u0 = 1 − τ0 / T when p0 < 0). With q = a + L (1 − cos πs)/2,
L = b − a, the end-point singularities cancel and Gauss–Legendre in s converges fast, as
in :func:`~nh_operators.models.phase_rules.period_quadrature` for the rest scene
(a = 0, b = 1, E = V0). The turning points are bracketed on a fine grid of the spline and
bisected to float64 precision.

These are the coordinates :class:`~nh_operators.models.StatePhaseONet` works in: it reads
the orbit's shape off ``U = E − V`` at fixed nodes and predicts q = a + L Q(h),
p = ± (L / T) P(h) at the half-phase h. Everything here is a function of the input only.
On the CPU the bisection, and the quadrature where no gradient flows through the state,
run as compiled loops over the rows (numba); the torch formulas serve other devices and
the flow's Jacobian by autograd. (:mod:`nh_operators.solvers` finds periods of any
potential by adaptive quadrature; this module is the fixed-rule, batched, differentiable
version the network needs.)
"""

import math

import numba
import numpy as np
import torch

from .._sensors import spline_coefficient_map, spline_matrix
from .float64_buffers import Float64Buffers
from .orbit_shape import edge_tables, harmonic_shape, shape_table

__all__ = ["NARROW", "SensorSpline", "composite_rule", "invert_rows", "orbit"]


class SensorSpline(Float64Buffers):
    """The not-a-knot cubic spline of m uniform sensor values as constant linear maps.

    Float64 buffers that follow the module's device and never its dtype
    (:class:`~nh_operators.models.float64_buffers.Float64Buffers`).

    Args:
        n_sensors: m.
        fine: points of the uniform bracketing grid (default 512).

    Example:
        >>> spline = SensorSpline()
        >>> x = torch.linspace(0, 1, 100, dtype=torch.float64)
        >>> c = (x ** 3) @ spline.maps()[0]            # a cubic is exact
        >>> round(spline.at(c[None], torch.tensor([[0.3]], dtype=torch.float64)).item(), 12)
        0.027
    """

    coefficient_map: torch.Tensor
    grid_map: torch.Tensor
    grid: torch.Tensor

    def __init__(self, n_sensors: int = 100, fine: int = 512) -> None:
        super().__init__()
        self.pieces = n_sensors - 1
        # (m, pieces · 4): column 4i + k is piece i's coefficient of dx^(3 − k)
        self.constant("coefficient_map", spline_coefficient_map(n_sensors))
        self.constant("grid_map", spline_matrix(np.linspace(0.0, 1.0, fine), n_sensors).T)
        self.constant("grid", torch.linspace(0.0, 1.0, fine, dtype=torch.float64))

    def maps(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(coefficient map (m, 4·pieces), grid map (m, fine), grid (fine,)), float64."""
        return self.coefficient_map, self.grid_map, self.grid

    def at(self, coefficients: torch.Tensor, x: torch.Tensor,
           derivative: int = 0) -> torch.Tensor:
        """Row i's spline (or its first or second derivative) at the points x[i].

        Args:
            coefficients: (B, 4·pieces) from ``V @ maps()[0]``.
            x: (B, K) points; outside [0, 1] the end pieces go on.
            derivative: 0, 1 or 2.

        Returns:
            (B, K).
        """
        i = torch.floor(x * self.pieces).clamp_(0, self.pieces - 1)
        dx = x - i / self.pieces
        index = (i.long() * 4)[..., None] + torch.arange(4, device=x.device)
        c = torch.gather(coefficients, 1, index.reshape(len(x), -1)).view(*x.shape, 4)
        if derivative == 1:
            return (3 * c[..., 0] * dx + 2 * c[..., 1]) * dx + c[..., 2]
        if derivative == 2:
            return 6 * c[..., 0] * dx + 2 * c[..., 1]
        return ((c[..., 0] * dx + c[..., 1]) * dx + c[..., 2]) * dx + c[..., 3]


def _turning_points(spline, coefficients, values, grid, q0, E, steps):
    """(a, b): the ends of the part of {V < E} around q0, each bracketed between an
    outside grid point and the inside end next to it and bisected ``steps`` times; the
    ends carry the derivative dx/dE = 1/V′(x) of V(x) = E for autograd (their values are
    the bisection's), so the flow's Jacobian in (q0, p0) goes through the turning
    points."""
    n = grid.numel()
    with torch.no_grad():
        inner, outer, left, right = _brackets(spline, coefficients, values, grid, q0,
                                              E.detach(), steps)
    ends = 0.5 * (inner + outer)
    if E.requires_grad:
        slope = spline.at(coefficients, ends, 1).detach()
        ok = slope.abs() > 1e-8
        shift = (E - E.detach())[:, None] / torch.where(ok, slope, torch.ones_like(slope))
        ends = ends + torch.where(ok, shift, torch.zeros_like(shift))
    a = torch.where(left < 0, torch.zeros_like(q0), ends[:, 0])   # open to a wall: clamp
    b = torch.where(right >= n, torch.ones_like(q0), ends[:, 1])
    return a, b


def _brackets(spline, coefficients, values, grid, q0, E, steps, compiled=None):
    """(inner, outer) (B, 2) ends of the bisected brackets of a and b, and the indices of
    the outside grid points next to them (−1 or the grid's size where there is none).

    ``compiled`` (default: on the CPU) runs :func:`_brackets_compiled`, the same
    arithmetic in one call: at batch 1 the torch version is ~500 tiny tensor operations
    (8 of a forward's 11 ms)."""
    if compiled is None:
        compiled = coefficients.device.type == "cpu"
    if compiled:
        c, v, g, q, e = (a.detach().numpy() for a in (coefficients, values, grid, q0, E))
        out = _brackets_compiled(c, v, g, q, e, steps, spline.pieces)
        return tuple(torch.from_numpy(o) for o in out)
    n = grid.numel()
    inside = values < E[:, None]
    # seed: the inside grid point nearest q0 (or q0 itself when the orbit is narrower
    # than the grid)
    distance = (grid[None] - q0[:, None]).abs() + 10.0 * (~inside)
    nearest = distance.argmin(1)
    has = inside.any(1)
    seed = torch.where(has, grid[nearest], q0)
    index = torch.arange(n, device=grid.device)
    outside = ~inside
    before = grid[None] < seed[:, None]
    left = torch.where(outside & before, index, -1).amax(1)
    right = torch.where(outside & (grid[None] > seed[:, None]), index, n).amin(1)
    left_out = grid[left.clamp(min=0)]
    left_in = torch.minimum(grid[(left + 1).clamp(max=n - 1)], seed)
    right_out = grid[right.clamp(max=n - 1)]
    right_in = torch.maximum(grid[(right - 1).clamp(min=0)], seed)
    inner = torch.stack([left_in, right_in], 1)
    outer = torch.stack([left_out, right_out], 1)
    for _ in range(steps):   # invariant: V(inner) < E ≤ V(outer)
        mid = 0.5 * (inner + outer)
        below = spline.at(coefficients, mid) < E[:, None]
        inner = torch.where(below, mid, inner)
        outer = torch.where(below, outer, mid)
    return inner, outer, left, right


@numba.njit(cache=True, nogil=True)
def _spline_value(c, pieces, x):
    i = min(max(math.floor(x * pieces), 0.0), pieces - 1.0)
    dx = x - i / pieces
    o = 4 * int(i)
    return ((c[o] * dx + c[o + 1]) * dx + c[o + 2]) * dx + c[o + 3]


@numba.njit(cache=True, nogil=True)
def _brackets_compiled(coefficients, values, grid, q0, E, steps, pieces):
    """:func:`_brackets` row by row, with the torch version's arithmetic."""
    rows, n = values.shape
    inner = np.empty((rows, 2))
    outer = np.empty((rows, 2))
    left = np.empty(rows, dtype=np.int64)
    right = np.empty(rows, dtype=np.int64)
    for r in range(rows):
        c, e = coefficients[r], E[r]
        nearest, best, has = 0, np.inf, False
        for k in range(n):
            inside = values[r, k] < e
            has = has or inside
            d = abs(grid[k] - q0[r]) + (0.0 if inside else 10.0)
            if d < best:
                nearest, best = k, d
        seed = grid[nearest] if has else q0[r]
        lo, hi = -1, n
        for k in range(n):
            if not values[r, k] < e:
                if grid[k] < seed:
                    lo = k
                elif grid[k] > seed and hi == n:
                    hi = k
        left[r], right[r] = lo, hi
        inner[r, 0] = min(grid[min(lo + 1, n - 1)], seed)
        outer[r, 0] = grid[max(lo, 0)]
        inner[r, 1] = max(grid[max(hi - 1, 0)], seed)
        outer[r, 1] = grid[min(hi, n - 1)]
        for j in range(2):   # invariant: V(inner) < E ≤ V(outer)
            i_, o_ = inner[r, j], outer[r, j]
            for _ in range(steps):
                mid = 0.5 * (i_ + o_)
                if _spline_value(c, pieces, mid) < e:
                    i_ = mid
                else:
                    o_ = mid
            inner[r, j], outer[r, j] = i_, o_
    return inner, outer, left, right


@numba.njit(cache=True, nogil=True)
def _integrand(c, pieces, a, L, E, x):
    """(dq/ds) / sqrt(2 (E − V)) at s = x, as :func:`orbit`'s torch integrand."""
    q = a + L * (1 - math.cos(math.pi * x)) / 2
    U = max(E - _spline_value(c, pieces, q), 1e-300)
    return L * (math.pi / 2) * math.sin(math.pi * x) / math.sqrt(2 * U)


@numba.njit(cache=True, nogil=True)
def _quadrature_compiled(coefficients, a, b, E, q0, nodes, s, w, pieces, grid, ends, cos_e,
                         sin_e, gaps):
    """T, the phase before its sign, U at ``nodes``, s0 of :func:`orbit`, and with
    ``grid`` > 0 the computed shape (Q, P) of :func:`.orbit_shape.shape_table` (with the
    rule's :func:`.orbit_shape.edge_tables`), row by row (the same formulas; libm's cos,
    sin and sqrt instead of torch's)."""
    rows, n_nodes, n_rule = a.shape[0], nodes.shape[0], s.shape[0]
    T, phase, s0s = np.empty(rows), np.empty(rows), np.empty(rows)
    U = np.empty((rows, n_nodes))
    Q, P = np.empty((rows, grid)), np.empty((rows, grid))
    f = np.empty(n_rule)
    for r in range(rows):
        c, e = coefficients[r], E[r]
        L = max(b[r] - a[r], 1e-12)
        for k in range(n_nodes):
            q = a[r] + L * (1 - math.cos(math.pi * nodes[k])) / 2
            U[r, k] = max(e - _spline_value(c, pieces, q), 1e-300)
        total = 0.0
        for k in range(n_rule):
            f[k] = _integrand(c, pieces, a[r], L, e, s[k])
            total += f[k] * w[k]
        T[r] = 2 * total
        if grid > 0:
            invert_row(f, s, w, T[r], ends, cos_e, sin_e, gaps, Q[r], P[r])
        s0 = math.acos(min(max(1 - 2 * (q0[r] - a[r]) / L, -1.0), 1.0)) / math.pi
        total = 0.0
        for k in range(n_rule):
            total += _integrand(c, pieces, a[r], L, e, s0 * s[k]) * w[k]
        phase[r] = s0 * total / T[r]
        s0s[r] = s0
    return T, phase, U, s0s, Q, P


@numba.njit(cache=True, nogil=True)
def invert_row(f, s, w, T, ends, cos_e, sin_e, gaps, Q, P):
    """:func:`.orbit_shape.shape_table` for one row, into Q and P (grid,), with the
    rule's :func:`.orbit_shape.edge_tables`; cos and sin of πs from their values at the
    end below s by angle addition (series of the small angle to its 7th power: exact to
    about 1e-13 for the intervals of 32 or more Gauss–Legendre nodes)."""
    K, grid = f.shape[0], Q.shape[0]
    phase = np.empty(K + 1)
    inverse = np.empty(K)
    per_phase = np.empty(K + 1)   # 1 / (phase[k] − phase[k − 1])
    phase[0], total, per_period = 0.0, 0.0, 1 / T
    for k in range(K):
        total += f[k] * w[k]
        phase[k + 1] = total * per_period
        inverse[k] = 1 / f[k]
        per_phase[k + 1] = 1 / max(phase[k + 1] - phase[k], 1e-300)
    right, node = 1, 1      # walk the table and the nodes once, h and s increasing
    step = 0.5 / (grid - 1)
    for g in range(grid):
        h = step * g
        while right < K and phase[right] < h:
            right += 1
        x = min(max((h - phase[right - 1]) * per_phase[right], 0.0), 1.0)
        width = ends[right] - ends[right - 1]
        at = ends[right - 1] + x * width
        a = math.pi * x * width
        a2 = a * a
        # products by inverse factorials (folded): a division costs several products
        sin_a = a * (1 - a2 * (1 / 6) * (1 - a2 * (1 / 20) * (1 - a2 * (1 / 42))))
        cos_a = 1 - a2 * 0.5 * (1 - a2 * (1 / 12) * (1 - a2 * (1 / 30)))
        c0, s0 = cos_e[right - 1], sin_e[right - 1]
        Q[g] = (1 - (c0 * cos_a - s0 * sin_a)) / 2
        while node < K - 1 and s[node] < at:   # s[node − 1] < at ≤ s[node], clamped
            node += 1
        y = min(max((at - s[node - 1]) * gaps[node], 0.0), 1.0)
        g_inv = inverse[node - 1] + y * (inverse[node] - inverse[node - 1])
        P[g] = T * (math.pi / 2) * (s0 * cos_a + c0 * sin_a) * g_inv


@numba.njit(cache=True, nogil=True)
def invert_rows(f, s, w, T, ends, cos_e, sin_e, gaps, grid):
    """:func:`invert_row` for every row: (Q, P), each (B, grid)."""
    rows = f.shape[0]
    Q, P = np.empty((rows, grid)), np.empty((rows, grid))
    for r in range(rows):
        invert_row(f[r], s, w, T[r], ends, cos_e, sin_e, gaps, Q[r], P[r])
    return Q, P


#: Orbits narrower than this (in q) take the harmonic limit of their well's bottom: there
#: E − V is below ~1e-8 and loses its digits to cancellation.
NARROW = 1e-4


def composite_rule(panels: int, nodes: int) -> tuple[torch.Tensor, torch.Tensor]:
    """Composite Gauss–Legendre on [0, 1]: ``panels`` equal panels of ``nodes`` nodes.

    Args:
        panels: number of equal panels.
        nodes: Gauss–Legendre nodes per panel.

    Returns:
        (s, w), each (panels · nodes,), float64 tensors; the weights sum to 1.

    Example:
        >>> s, w = composite_rule(4, 3)
        >>> round(float((s ** 5) @ w), 14)   # exact for degree ≤ 5: ∫ s⁵ = 1/6
        0.16666666666667
    """
    x, v = np.polynomial.legendre.leggauss(nodes)
    left = np.arange(panels)[:, None] / panels
    s = (left + (x[None] + 1) / (2 * panels)).reshape(-1)
    return torch.tensor(s), torch.tensor(np.tile(v / (2 * panels), panels))


def orbit(spline: SensorSpline, V: torch.Tensor, q0: torch.Tensor, p0: torch.Tensor,
          nodes: torch.Tensor, rule: tuple[torch.Tensor, torch.Tensor], steps: int = 48,
          shape_grid: int = 0) -> dict[str, torch.Tensor]:
    """The orbit through (q0, p0) in the sensor spline of each row's V.

    Args:
        spline: a :class:`SensorSpline` for V's sensor count, on V's device.
        V: (B, m) sensor values; q0, p0: (B,) states (all float64).
        nodes: (K,) points s ∈ (0, 1) where U = E − V is read (float64).
        rule: (s, w) of the quadrature of T and u0, each (R,) float64 on [0, 1]; a
            composite rule (:func:`composite_rule`) resolves the slow passage over a
            barrier top that an orbit just above a separatrix makes inside [a, b].
        steps: bisection steps per turning point (48: below float64's resolution of a
            grid cell).
        shape_grid: with a positive count, also the orbit's shape computed on that many
            nodes of the half-phase (:mod:`.orbit_shape`, on ``rule``).

    Returns:
        dict with a, b, E, T, u0 of shape (B,) and U (B, K) = E − V at the nodes
        q = a + (b − a)(1 − cos πs)/2 (clamped at 1e-300 above zero). An orbit narrower
        than :data:`NARROW` gets the harmonic limit: T = 2π / sqrt(V″) at its middle,
        u0 from q = a + L (1 − cos 2πu)/2, and U ∝ sin²(πs) scaled by V″ L² / 8. With
        ``shape_grid``, also Q and P (B, shape_grid): q = a + L Q(h), |p| = (L / T) P(h)
        at the half-phase h (the harmonic orbit's for a narrow one).

    Example:
        >>> x = torch.linspace(0, 1, 100, dtype=torch.float64)
        >>> V = (2 - 8 * x * (1 - x))[None]                 # harmonic, ω = 4
        >>> zero = torch.zeros(1, dtype=torch.float64)
        >>> o = orbit(SensorSpline(), V, zero, zero, composite_rule(1, 8)[0],
        ...           composite_rule(4, 16))
        >>> round(o["T"].item(), 10), round(o["b"].item(), 10)   # π / 2, the far wall
        (1.5707963268, 1.0)
    """
    coef_map, grid_map, grid = spline.maps()
    coefficients = V @ coef_map
    E = 0.5 * p0 * p0 + spline.at(coefficients, q0[:, None])[:, 0]
    a, b = _turning_points(spline, coefficients, V @ grid_map, grid, q0, E, steps)
    L = (b - a).clamp(min=1e-12)

    def integrand(x):   # (B, K) points in s ∈ [0, 1] → (dq/ds) / |p|, and E − V
        q = a[:, None] + L[:, None] * (1 - torch.cos(math.pi * x)) / 2
        U = (E[:, None] - spline.at(coefficients, q)).clamp(min=1e-300)
        jac = L[:, None] * (math.pi / 2) * torch.sin(math.pi * x)
        return jac * torch.rsqrt(2 * U), U

    rule_s, rule_w = rule
    needs_grad = torch.is_grad_enabled() and any(x.requires_grad for x in (V, q0, p0))
    if V.device.type == "cpu" and not needs_grad:
        # a function of the input alone: one compiled pass instead of (B, K) tensors
        c, a_, b_, E_, q0_, s_, rs, rw = (x.detach().numpy() for x in (
            coefficients, a, b, E, q0, nodes, rule_s, rule_w))
        ends, cos_e, sin_e, gaps = edge_tables(rs, rw)
        out = _quadrature_compiled(c, a_, b_, E_, q0_, s_, rs, rw, spline.pieces, shape_grid,
                                   ends, cos_e, sin_e, gaps)
        T, phase, U, s0, Q, P = (torch.from_numpy(x) for x in out)
    else:
        _, U = integrand(nodes[None].expand(len(V), -1))
        f, _ = integrand(rule_s[None].expand(len(V), -1))
        T = 2 * (f @ rule_w)
        if shape_grid:
            Q, P = shape_table(f, rule_s, rule_w, T, shape_grid)
        s0 = torch.arccos((1 - 2 * (q0 - a) / L).clamp(-1.0, 1.0)) / math.pi
        f0, _ = integrand(s0[:, None] * rule_s[None])
        phase = s0 * (f0 @ rule_w) / T
    narrow = L < NARROW
    if bool(narrow.any()):
        curvature = spline.at(coefficients, (0.5 * (a + b))[:, None], 2)[:, 0].clamp(min=1e-12)
        T = torch.where(narrow, 2 * math.pi * torch.rsqrt(curvature), T)
        phase = torch.where(narrow, s0 / 2, phase)
        harmonic = (curvature * L * L / 8)[:, None] * torch.sin(math.pi * nodes)[None] ** 2
        U = torch.where(narrow[:, None], harmonic.clamp(min=1e-300), U)
        if shape_grid:
            Qh, Ph = harmonic_shape(shape_grid, Q.dtype, Q.device)
            Q = torch.where(narrow[:, None], Qh, Q)
            P = torch.where(narrow[:, None], Ph, P)
    u0 = torch.where(p0 >= 0, phase, 1 - phase)
    out = {"a": a, "b": b, "E": E, "T": T, "u0": u0, "U": U}
    if shape_grid:
        out.update(Q=Q, P=P)
    return out
