"""Unbounded potentials through a bounded extension (the paper's free-fall construction).

A particle released at rest at q = 0 in a potential V that decreases on [0, Q] (V(0) =
V0) runs down the slope and reaches Q at the time T = ∫₀^Q dq / sqrt(2(V0 − V(q))).
Until then its trajectory does not depend on V beyond Q, so V may be replaced there by
any C² extension P on (Q, 1] with P(Q) = V(Q), P′(Q) = V′(Q), P″(Q) = V″(Q), P(1) = V0
and P < V0 inside: the result is a bounded potential, which networks and solvers take,
and its trajectory on [0, T] is the one of V.

P is the polynomial in s = q − Q, with L = 1 − Q,

    P(s) = V(Q) + V′(Q) s + V″(Q) s²/2 + R (s/L)^k,  R = V0 − V(Q) − V′(Q) L − V″(Q) L²/2,

with the smallest k ≥ 3 for which P < V0 on (Q, 1) (k = 3 is the paper's cubic: for the
free fall V = −4(q − 1/2), Q = 1/2, it gives P = 32q³ − 48q² + 20q − 2).
"""

import numpy as np

from .._constants import V0 as DEFAULT_V0
from .coerce import CallablePotential

__all__ = ["ExtendedPotential", "extend_monotone"]

_GRID = 2001


class ExtendedPotential:
    """V on [0, Q], its polynomial extension on (Q, 1] (final; see the module docstring).

    Attributes:
        Q: where the extension starts.
        T: the time at which the particle reaches Q; the trajectory is that of the
            original potential on [0, T].
        k: the degree of the extension's last term.
        name, formula: for tables and figures.
    """

    def __init__(self, V, dV, Q, v, d1, d2, k, R, T, V0, name):
        self._V, self._dV = V, dV
        self.Q, self.T, self.k, self.V0 = float(Q), float(T), int(k), float(V0)
        self._c = (float(v), float(d1), float(d2), float(R), 1.0 - float(Q))
        self.name = name
        self.formula = f"{name} on [0, {self.Q:g}], polynomial extension (k = {self.k}) beyond"

    def _poly(self, q, derivative):
        v, d1, d2, R, L = self._c
        s = q - self.Q
        k = self.k
        if derivative == 0:
            return v + d1 * s + 0.5 * d2 * s**2 + R * (s / L) ** k
        return d1 + d2 * s + R * k * s ** (k - 1) / L**k

    def _piecewise(self, q, fn, derivative):
        q = np.asarray(q, dtype=np.float64)
        inside = q <= self.Q
        out = np.empty_like(q)
        out[inside] = np.asarray(fn(q[inside]), dtype=np.float64)
        out[~inside] = self._poly(q[~inside], derivative)
        return out if out.ndim else float(out)

    def V(self, q):
        """The potential: V on [0, Q], the extension beyond."""
        return self._piecewise(q, self._V, 0)

    def dV(self, q):
        """Its derivative."""
        return self._piecewise(q, self._dV, 1)


def _one_sided_second_derivative(dV, Q, h=1e-4):
    """V″(Q) from values of V′ on [0, Q] only (second-order one-sided difference)."""
    d = dV(np.array([Q, Q - h, Q - 2 * h]))
    return (3 * d[0] - 4 * d[1] + d[2]) / (2 * h)


def extend_monotone(V, Q, dV=None, V0=DEFAULT_V0, *, d2V=None, name=None):
    """A bounded potential equal to ``V`` on [0, Q], with the time ``T`` at which q = Q.

    Args:
        V: vectorised callable q -> V(q), decreasing on [0, Q] from V(0) = V0.
        Q: end of the original potential's domain, 0 < Q < 1.
        dV: its derivative (default: a fourth-order central difference of V).
        V0: the energy, V(0) (default 2, the networks' V0).
        d2V: its second derivative at Q (default: a one-sided difference of dV).
        name: a label (default: the callable's name).

    Returns:
        :class:`ExtendedPotential` with ``V``, ``dV``, ``T``, ``Q``.

    Raises:
        ValueError: if Q is not in (0, 1), V(0) ≠ V0, V is not decreasing on [0, Q]
            (checked on 2,001 points), V′(0) = 0 (the particle stays at rest, T = ∞),
            or no extension of the family stays below V0.

    Example:
        >>> free_fall = extend_monotone(lambda q: -4 * (q - 0.5), 0.5, lambda q: -4 + 0 * q)
        >>> round(free_fall.T, 12), float(free_fall.V(0.75)), free_fall.k
        (0.5, -0.5, 3)
    """
    if not (isinstance(Q, (int, float, np.floating)) and 0 < Q < 1):
        raise ValueError(f"Q must lie in (0, 1), got {Q!r}")
    name = name or getattr(V, "__name__", "V")
    name = "V" if name == "<lambda>" else name
    if dV is None:
        dV = CallablePotential(V).dV  # the solver's fourth-order central difference

    q = np.linspace(0.0, Q, _GRID)
    values = np.asarray(V(q), dtype=np.float64)
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{name} is not finite on [0, {Q:g}]")
    if abs(values[0] - V0) > 1e-8:
        raise ValueError(f"{name}(0) = {values[0]:.6g}, but the particle starts at rest at "
                         f"q = 0 with energy V0 = {V0:g}: need V(0) = V0")
    rises = np.flatnonzero(np.diff(values) > 1e-12 * max(1.0, abs(V0)))
    if rises.size:
        at = q[rises[0]]
        raise ValueError(f"{name} is not decreasing on [0, {Q:g}]: it rises after q = "
                         f"{at:.4g}, so the particle would turn back before Q")
    v = float(values[-1])
    d1 = float(np.asarray(dV(np.array([Q])))[0])
    d0 = float(np.asarray(dV(np.array([0.0])))[0])
    if d0 >= 0:
        raise ValueError(f"{name}'(0) = {d0:.3g}: at rest on a flat or rising slope the "
                         "particle never leaves q = 0 (T is infinite)")
    d2 = float(d2V(Q)) if d2V is not None else float(_one_sided_second_derivative(dV, Q))
    L = 1.0 - Q
    R = V0 - v - d1 * L - 0.5 * d2 * L**2
    s = np.linspace(0.0, L, _GRID)[1:-1]
    for k in range(3, 16):
        P = v + d1 * s + 0.5 * d2 * s**2 + R * (s / L) ** k
        if np.all(P < V0):
            break
    else:
        raise ValueError(f"no extension P(q) = V(Q) + V'(Q)s + V''(Q)s²/2 + R(s/(1-Q))^k, "
                         f"3 ≤ k ≤ 15, stays below V0 = {V0:g} on ({Q:g}, 1): V(Q) = {v:.4g}, "
                         f"V'(Q) = {d1:.4g}, V''(Q) = {d2:.4g}. A smaller Q leaves more room")

    def integrand(u):  # q = Q u²: the 1/sqrt(q) singularity at q = 0 is gone
        gap = V0 - float(np.asarray(V(np.array([Q * u * u])))[0])
        return 2.0 * Q * u / np.sqrt(2.0 * gap) if gap > 0 else np.sqrt(2.0 * Q / -d0)

    from scipy import integrate  # only here: a slow import

    T, _ = integrate.quad(integrand, 0.0, 1.0, epsabs=1e-13, epsrel=1e-12, limit=200)
    return ExtendedPotential(V, dV, Q, v, d1, d2, k, R, T, V0, name)
