"""Bounded potentials from outside the training distribution, with exact derivatives.

The generator draws clamped cubic B-splines through a few random control points; these
families are built differently (closed formulas, other shapes), so a network trained on
the generator has not seen them, while a classical solver does not care. They test
claims that should hold beyond the training set, such as :func:`~nh_operators.solve`'s
tolerance contract.

* ``power_well``: 2 − A·qᵃ(1 − q)ᵇ / max, asymmetric wells (a, b ∈ [2, 5]);
* ``ripple``: 2 − sin²(πq)·(A + B sin(2πkq)), B < A: several wells of unequal depth;
* ``flat_bottom``: 2 − A·tanh(kq)·tanh(k(1 − q)), walls of width ~1/k (k up to 30);
* ``gaussian_wells``: 2 − sin²(πq)·(B + Σ Aᵢ exp(−(q − cᵢ)² / 2sᵢ²)), narrow dips
  (s ≥ 0.04) in a broad well.

Every member satisfies V(0) = V(1) = 2 > V(q) on (0, 1) and is C∞ on [0, 1].
"""

import numpy as np

from .physical import AnalyticPotential

__all__ = ["OOD_FAMILIES", "ood_potential", "ood_potentials"]

#: family name -> description
OOD_FAMILIES = {
    "power_well": "2 - A q^a (1-q)^b / max, a, b in [2, 5], A in [1, 4]",
    "ripple": "2 - sin²(πq) (A + B sin(2πkq)), A in [1, 4], B in [0.2, 0.8] A, k in 2..6",
    "flat_bottom": "2 - A tanh(kq) tanh(k(1-q)), A in [1, 4], k in [5, 30]",
    "gaussian_wells": "2 - sin²(πq) (B + Σ A_i exp(-(q-c_i)²/2s_i²)), B in [0.5, 2], 1-3 "
                      "wells, A_i in [1, 6], s_i in [0.04, 0.2]",
}


def _power_well(rng):
    a, b, A = rng.uniform(2, 5), rng.uniform(2, 5), rng.uniform(1, 4)
    top = (a / (a + b)) ** a * (b / (a + b)) ** b
    k = A / top

    def inside(q):  # fractional powers: continued by V(0) = V(1) = 2 outside [0, 1]
        return np.clip(q, 0.0, 1.0)

    def V(q):
        x = inside(q)
        return 2.0 - k * x**a * (1.0 - x) ** b

    def dV(q):
        x = inside(q)
        return -k * x ** (a - 1) * (1.0 - x) ** (b - 1) * (a * (1.0 - x) - b * x)

    return V, dV, f"2 - {A:.3g} q^{a:.3g} (1-q)^{b:.3g} / {top:.3g}"


def _ripple(rng):
    A = rng.uniform(1, 4)
    B = rng.uniform(0.2, 0.8) * A
    k = int(rng.integers(2, 7))

    def V(q):
        return 2.0 - np.sin(np.pi * q) ** 2 * (A + B * np.sin(2 * np.pi * k * q))

    def dV(q):
        s, c = np.sin(np.pi * q), np.cos(np.pi * q)
        return -(2 * np.pi * s * c * (A + B * np.sin(2 * np.pi * k * q))
                 + s**2 * B * 2 * np.pi * k * np.cos(2 * np.pi * k * q))

    return V, dV, f"2 - sin²(πq) ({A:.3g} + {B:.3g} sin({2 * k}πq))"


def _flat_bottom(rng):
    A, k = rng.uniform(1, 4), rng.uniform(5, 30)

    def V(q):
        return 2.0 - A * np.tanh(k * q) * np.tanh(k * (1.0 - q))

    def dV(q):
        a, b = np.tanh(k * q), np.tanh(k * (1.0 - q))
        return -A * k * ((1 - a**2) * b - a * (1 - b**2))

    return V, dV, f"2 - {A:.3g} tanh({k:.3g}q) tanh({k:.3g}(1-q))"


def _gaussian_wells(rng):
    m = int(rng.integers(1, 4))
    A, c, s = rng.uniform(1, 6, m), rng.uniform(0.15, 0.85, m), rng.uniform(0.04, 0.2, m)
    base = rng.uniform(0.5, 2.0)

    def G(q):
        q = np.asarray(q)[..., None]
        g = A * np.exp(-((q - c) ** 2) / (2 * s**2))
        return base + g.sum(-1), (g * -(q - c) / s**2).sum(-1)

    def V(q):
        return 2.0 - np.sin(np.pi * q) ** 2 * G(q)[0]

    def dV(q):
        g, dg = G(q)
        sn, cs = np.sin(np.pi * q), np.cos(np.pi * q)
        return -(2 * np.pi * sn * cs * g + sn**2 * dg)

    terms = f"{base:.2g} + " + " + ".join(f"{a:.2g} e^(-(q-{x:.2g})²/2·{w:.2g}²)"
                                          for a, x, w in zip(A, c, s, strict=True))
    return V, dV, f"2 - sin²(πq) ({terms})"


_BUILDERS = {"power_well": _power_well, "ripple": _ripple, "flat_bottom": _flat_bottom,
             "gaussian_wells": _gaussian_wells}


def ood_potential(family, rng):
    """One random member of ``family`` as an :class:`~nh_operators.AnalyticPotential`.

    Args:
        family: a key of :data:`OOD_FAMILIES`.
        rng: a ``numpy.random.Generator``.

    Raises:
        ValueError: for an unknown family.
    """
    if family not in _BUILDERS:
        raise ValueError(f"unknown family {family!r}; choose one of {sorted(_BUILDERS)}")
    V, dV, formula = _BUILDERS[family](rng)
    return AnalyticPotential(family, formula, V, dV)


def ood_potentials(n, seed, families=None):
    """``n`` potentials cycling through ``families`` (default: all), reproducibly.

    Args:
        n: how many.
        seed: seed of the ``numpy.random.Generator`` that draws them.
        families: names from :data:`OOD_FAMILIES`.

    Returns:
        list of :class:`~nh_operators.AnalyticPotential`.

    Example:
        >>> pots = ood_potentials(8, seed=1)
        >>> [p.name for p in pots[:4]]
        ['power_well', 'ripple', 'flat_bottom', 'gaussian_wells']
    """
    families = list(OOD_FAMILIES if families is None else families)
    rng = np.random.default_rng(seed)
    return [ood_potential(families[i % len(families)], rng) for i in range(n)]
