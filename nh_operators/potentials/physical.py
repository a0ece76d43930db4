"""The paper's physically relevant test potentials (its Table of test potentials).

All are bounded potentials on [0, 1] with V(0) = V(1) = 2. SHO and mirrored free fall
(MFF) have exact trajectories; the others are compared with the reference solver.
"""

import math

import numpy as np

__all__ = ["AnalyticPotential", "PHYSICAL_POTENTIALS"]


class AnalyticPotential:
    """A potential given by formulas.

    Args:
        name: short key, e.g. ``"sho"``.
        formula: the formula as text, for tables and figures.
        V: vectorised callable q -> V(q).
        dV: vectorised callable q -> dV/dq.
        exact: optional callable t -> (q, p), the exact trajectory from rest at q = 0.
        exact_from_state: optional callable (t, q0, p0) -> (q, p), the exact trajectory
            from any state.
        smooth: whether V is C² (False for a kink such as the MFF's absolute value: the
            classical solver then credits no convergence order to its error estimate).

    Example:
        >>> sho = PHYSICAL_POTENTIALS["sho"]
        >>> q, p = sho.exact(np.array([0.0]))
        >>> float(q[0]), float(p[0])
        (0.0, 0.0)
    """

    def __init__(self, name, formula, V, dV, exact=None, exact_from_state=None, smooth=True):
        self.name = name
        self.smooth = bool(smooth)
        self.formula = formula
        self._V = V
        self._dV = dV
        self._exact = exact
        self._exact_from_state = exact_from_state

    def V(self, q):
        return self._V(np.asarray(q, dtype=np.float64))

    def dV(self, q):
        return self._dV(np.asarray(q, dtype=np.float64))

    def exact(self, t, q0=0.0, p0=0.0):
        """Exact (q(t), p(t)) from the state (q0, p0) (default: the paper's, at rest at
        q = 0), as float64 arrays of the shape of t; None if unknown."""
        t = np.asarray(t, dtype=np.float64)
        if q0 == 0.0 and p0 == 0.0 and self._exact is not None:
            return self._exact(t)
        if self._exact_from_state is None:
            return None
        return self._exact_from_state(t, float(q0), float(p0))

    def __repr__(self):
        return f"AnalyticPotential({self.name!r}, V = {self.formula})"


def _sho_exact(t):
    return 0.5 * (1.0 - np.cos(4.0 * t)), 2.0 * np.sin(4.0 * t)


def _sho_from_state(t, q0, p0):
    # V = 8 (q - 1/2)²: q = 1/2 + A cos(4t + φ), p = -4 A sin(4t + φ), T = π/2.
    A, phi = math.hypot(q0 - 0.5, p0 / 4), math.atan2(-p0 / 4, q0 - 0.5)
    return 0.5 + A * np.cos(4 * t + phi), -4 * A * np.sin(4 * t + phi)


def _mff_exact(t):
    # Period 2: fall from q = 0 to 1/2 (t < 1/2), rise to 1 and back to 1/2 (t < 3/2),
    # and return to 0; the formulas of the paper, extended periodically.
    s = np.mod(t, 2.0)
    q = np.where(s < 0.5, 2 * s**2, np.where(s < 1.5, -2 * s**2 + 4 * s - 1, 2 * (2 - s) ** 2))
    p = np.where(s < 0.5, 4 * s, np.where(s < 1.5, 4 - 4 * s, -4 * (2 - s)))
    return q, p


def _mff_from_state(t, q0, p0):
    """V = 4 |q - 1/2| from any state: parabolas glued at q = 1/2, period sqrt(2E)."""
    period = math.sqrt(2 * (0.5 * p0**2 + 4 * abs(q0 - 0.5)))
    qs, ps = np.empty(t.shape), np.empty(t.shape)
    for k, tk in np.ndenumerate(t):
        q, p, left = q0, p0, math.fmod(tk, period)
        while True:
            s = 1.0 if q > 0.5 or (q == 0.5 and p > 0) else -1.0  # side; acceleration -4 s
            tau = (s * p + math.sqrt(p * p + 8 * abs(q - 0.5))) / 4  # time to reach 1/2
            if tau <= 0:
                tau = s * p / 2 if s * p > 0 else 0.0
            if left < tau or tau == 0.0 and p == 0:
                q, p = q + p * left - 2 * s * left**2, p - 4 * s * left
                break
            q, p, left = 0.5, p - 4 * s * tau, left - tau
        qs[k], ps[k] = q, p
    return qs, ps


#: Depth D_e and width a of the physical Morse potential D_e (1 - exp(-a (q - 1/3)))².
MORSE_DE = 8.0 / (math.sqrt(5.0) - 1.0) ** 2
MORSE_A = 3.0 * math.log((1.0 + math.sqrt(5.0)) / 2.0)


def _morse_V(q):
    return MORSE_DE * (1.0 - np.exp(-MORSE_A * (q - 1.0 / 3.0))) ** 2


def _morse_dV(q):
    e = np.exp(-MORSE_A * (q - 1.0 / 3.0))
    return 2.0 * MORSE_DE * MORSE_A * e * (1.0 - e)


#: α of the physical SMFF (the paper's value).
SMFF_ALPHA = 20.0


def smff(alpha):
    """Softened mirrored free fall, V = 4 tanh(α/2) (q - 1/2) coth(α (q - 1/2)).

    The removable singularity at q = 1/2 is evaluated from the Taylor series of
    u coth u, so V and dV are accurate to rounding everywhere.
    """
    scale = 4.0 * math.tanh(alpha / 2.0) / alpha

    def ucothu(u):
        small = np.abs(u) < 0.1
        us = np.where(small, 1.0, u)
        u2 = u * u
        series = 1 + u2 / 3 - u2**2 / 45 + 2 * u2**3 / 945 - u2**4 / 4725 + 2 * u2**5 / 93555
        return np.where(small, series, us / np.tanh(us))

    def ducothu(u):
        small = np.abs(u) < 0.1
        us = np.where(small, 1.0, u)
        u2 = u * u
        series = u * (2 / 3 - 4 * u2 / 45 + 12 * u2**2 / 945 - 8 * u2**3 / 4725
                      + 20 * u2**4 / 93555)
        with np.errstate(over="ignore"):  # sinh overflows to inf for |u| > 710: u/inf² = 0
            return np.where(small, series, 1 / np.tanh(us) - us / np.sinh(us) ** 2)

    return AnalyticPotential(
        "smff",
        f"4/coth({alpha:g}/2) (q - 1/2) coth({alpha:g} (q - 1/2))",
        lambda q: scale * ucothu(alpha * (q - 0.5)),
        lambda q: scale * alpha * ducothu(alpha * (q - 0.5)),
    )


#: The paper's five test potentials by name: ``"sho"``, ``"double_well"``, ``"morse"``,
#: ``"mff"`` (mirrored free fall) and ``"smff"`` (its smoothed form, α = 20); each an
#: :class:`AnalyticPotential`.
PHYSICAL_POTENTIALS = {
    "sho": AnalyticPotential(
        "sho", "8 (q - 1/2)^2", lambda q: 8 * (q - 0.5) ** 2, lambda q: 16 * (q - 0.5), _sho_exact,
        _sho_from_state,
    ),
    "double_well": AnalyticPotential(
        "double_well",
        "625/8 (q - 0.2)^2 (q - 0.8)^2",
        lambda q: 625 / 8 * (q - 0.2) ** 2 * (q - 0.8) ** 2,
        lambda q: 625 / 4 * (q - 0.2) * (q - 0.8) * (2 * q - 1.0),
    ),
    "morse": AnalyticPotential("morse", "D_e (1 - exp(-a (q - 1/3)))^2", _morse_V, _morse_dV),
    "mff": AnalyticPotential(
        "mff", "4 |q - 1/2|", lambda q: 4 * np.abs(q - 0.5), lambda q: 4 * np.sign(q - 0.5),
        _mff_exact, _mff_from_state, smooth=False,
    ),
    "smff": smff(SMFF_ALPHA),
}
