"""Stability at the extremes: inputs that push the numerics, and what each method does.

Five bounded potentials far from the paper's generator (:data:`EXTREME_CASES`): a steep
wall, a near-flat potential, a deep well and two kinks. :func:`stability_table` runs any
methods ``method(V, t) -> (q, p)`` on their sensor values and records, per case, whether
the outputs are finite, L_tot against a trusted reference, the energy error on the true
potential and the warnings raised; :func:`stability_markdown` makes the report section.

Where an input is outside what a method can do, a warning says so:

- :class:`ResolutionWarning` (from :mod:`nh_operators.solvers`): a fixed step too coarse
  for the potential's curvature, an energy drift (a deep well can fail with a step that
  looks fine for its curvature), or a kink; the message names the substeps that suffice.
- :class:`OutOfDomainWarning`: sensor values unlike anything the paper's generator makes,
  hence unlike a network's training data;
  :func:`~nh_operators.potentials.domain_violations` gives the reasons.

Limitation: nothing computed from the sensors alone tells whether they resolve V. A wall
narrower than the sensor spacing 1/99 leaves only a big jump between two sensors, and a
spike between two sensors leaves no trace. A leave-half-out estimate (the spline of the
even sensors, checked at the odd ones) reaches 0.035 on the generator's own potentials,
whose true curvature the sensors also miss (16,600 on the curve against 3,700 on the
spline), and 0.12 on the steep wall: it does not separate "unresolved" from "usual", so
no warning is raised for it. The domain checks flag the steep wall by its slope instead.
"""

import math
import warnings

import numpy as np

from .._constants import SENSORS, TIMES, V0
from .._metrics import energy_error, loss_per_sample
from ..potentials import PHYSICAL_POTENTIALS, AnalyticPotential
from ..potentials.physical import smff
from ..solvers import RESOLUTION_FRACTION, STABILITY_LIMITS, reference_solve

__all__ = ["EXTREME_CASES", "ENERGY_BOUNDS", "extreme_potentials", "extreme_reference",
           "case_properties", "stability_table", "stability_markdown"]


#: name -> one-line description of each extreme case, in report order.
EXTREME_CASES = {
    "steep_wall": "exponential walls of width 1/100 (one sensor spacing) at both ends, "
                  "V'(0) = -200, flat floor V ≈ 0",
    "near_flat": "shallow parabola 2 - 0.04 q (1 - q) ≥ 1.99: the particle creeps to "
                 "q ≈ 0.08 by t = 2 (exact solution)",
    "deep_well": "Pöschl–Teller well C - D sech²(6 (q - 1/2)) with min V = -100, speeds "
                 "up to 14 (exact solution)",
    "mff": "mirrored free fall 4 |q - 1/2|: the force jumps at q = 1/2 (exact solution)",
    "smff_200": "softened MFF with α = 200: the kink rounded over a width 1/200, half a "
                "sensor spacing",
}

#: Largest energy error max_t ``|p²/2 + V(q) - V0|`` on the true potential, t ∈ [0, 2], that
#: the tests allow (measured maxima over the cases they cover, times about 3 or more).
#: ``rk4_exact_16``: RK4, 16 steps per output interval, on the formula of V, every case
#: but MFF: 2.6e-4 (deep well), 1.2e-5 (steep wall), 9e-8 (SMFF), 0 (near flat).
#: ``yoshida8_exact_16``: 3.4e-7 (deep well), 4.9e-8 (steep wall). ``sensors_16``: RK4 or
#: Yoshida-8 at 16 steps on the sensor spline, every case: the spline's own error rules,
#: 1.9e-2 on the steep wall (unresolved by the sensors), 2.4e-3 on MFF, ≤ 8.6e-4 else.
#: Over t ∈ [0, 20] Yoshida-8 at 4 steps keeps the energy of the spline bounded on the
#: smooth cases (last 2 time units against the first 2: x1.05 steep wall, x1.37 deep
#: well) while RK4 drifts (x31, x14); across the kinks even Yoshida-8 drifts slowly (x2 to
#: x6, staying below 3e-4), the spline being only C² there.
ENERGY_BOUNDS = {"rk4_exact_16": 1e-3, "yoshida8_exact_16": 1e-6, "sensors_16": 6e-2}

# ------------------------------------------------------------------ the potentials


def _linear_outside(V, dV, margin=0.25):
    """Continue V linearly beyond [-margin, 1 + margin], so that a step thrown far out of
    the box stays finite (the formula is kept near [0, 1], where the turning points are)."""

    def value(q):
        inside = np.clip(q, -margin, 1.0 + margin)
        return V(inside) + dV(inside) * (q - inside)

    return value, lambda q: dV(np.clip(q, -margin, 1.0 + margin))


def _steep_wall(k=100.0, depth=2.0):
    def V(q):
        return V0 - depth * -np.expm1(-k * q) * -np.expm1(-k * (1.0 - q))

    def dV(q):
        a, b = np.exp(-k * q), np.exp(-k * (1.0 - q))
        return -depth * k * (a * (1.0 - b) - (1.0 - a) * b)

    return AnalyticPotential("steep_wall", f"2 - {depth:g} (1 - e^(-{k:g} q)) (1 - e^(-{k:g} "
                             "(1 - q)))", *_linear_outside(V, dV))


def _near_flat(delta=0.01):
    omega = math.sqrt(8.0 * delta)

    def exact(t):
        return 0.5 * (1.0 - np.cos(omega * t)), 0.5 * omega * np.sin(omega * t)

    return AnalyticPotential("near_flat", f"2 - {4 * delta:g} q (1 - q)",
                             lambda q: V0 - 4.0 * delta * q * (1.0 - q),
                             lambda q: -4.0 * delta * (1.0 - 2.0 * q), exact)


def _deep_well(k=6.0, v_min=-100.0):
    # V = C - D sech²(k x), x = q - 1/2, with V(±1/2) = V0 and V(0) = v_min. Relative to C
    # the energy is -D s0 (s0 = sech²(k/2)), and sinh(k x) = -sinh(k/2) cos(Ω t) with
    # Ω = k sqrt(2 D s0) solves Hamilton's equations from rest at x = -1/2.
    s0 = 1.0 / math.cosh(k / 2) ** 2
    D = (V0 - v_min) / (1.0 - s0)
    C = V0 + D * s0
    A = math.sinh(k / 2)
    W = k * math.sqrt(2.0 * D * s0)

    def exact(t):
        c = np.cos(W * t)
        return 0.5 + np.arcsinh(-A * c) / k, A * W * np.sin(W * t) / (k * np.hypot(1.0, A * c))

    return AnalyticPotential(
        "deep_well", f"{C:.6g} - {D:.6g} sech²({k:g} (q - 1/2))",
        lambda q: C - D / np.cosh(k * (q - 0.5)) ** 2,
        lambda q: 2.0 * D * k * np.tanh(k * (q - 0.5)) / np.cosh(k * (q - 0.5)) ** 2, exact)


def extreme_potentials():
    """The extreme cases as potentials, in the order of :data:`EXTREME_CASES`.

    Returns:
        dict name -> :class:`~nh_operators.AnalyticPotential` with vectorised ``V`` and
        ``dV`` (and ``exact`` where known). Each is a bounded potential on [0, 1]; the
        steep wall continues linearly beyond [-1/4, 5/4] so that it stays finite.

    Example:
        >>> pots = extreme_potentials()
        >>> list(pots) == list(EXTREME_CASES)
        True
        >>> round(float(pots["steep_wall"].dV(0.0)))
        -200
    """
    return {"steep_wall": _steep_wall(), "near_flat": _near_flat(), "deep_well": _deep_well(),
            "mff": PHYSICAL_POTENTIALS["mff"], "smff_200": smff(200.0)}


def extreme_reference(name, t=TIMES):
    """Reference (q, p) of an extreme case: exact where known, else DOP853 at 1e-13.

    Args:
        name: a key of :data:`EXTREME_CASES`.
        t: query times, shape (M,).

    Returns:
        (q, p), float64 arrays of shape (M,).

    Raises:
        KeyError: for an unknown case.

    Example:
        >>> q, p = extreme_reference("near_flat", [0.0, 2.0])
        >>> round(float(q[1]), 4)
        0.0779
    """
    if name not in EXTREME_CASES:
        raise KeyError(f"unknown case {name!r}; choose from {list(EXTREME_CASES)}")
    pot = extreme_potentials()[name]
    exact = pot.exact(np.asarray(t, dtype=np.float64))
    if exact is not None:
        return exact
    with np.errstate(over="ignore"):  # DOP853's first trial steps probe SMFF far outside
        return reference_solve(pot, t)


def case_properties(potential):
    """Measured properties of a potential: V'(0), min V, max V inside, max ``|V''|`` at sensors.

    Args:
        potential: an object with vectorised ``V`` and ``dV``.

    Returns:
        dict of floats ``dV0`` (V'(0)), ``min_V``, ``max_V_inside`` (on a 10,001-point
        grid, ends excluded) and ``sensor_curvature`` (max ``|second difference|`` · 99²).
    """
    q = np.linspace(0.0, 1.0, 10_001)
    values = potential.V(q)
    sensors = potential.V(SENSORS)
    return {"dV0": float(potential.dV(0.0)), "min_V": float(values.min()),
            "max_V_inside": float(values[1:-1].max()),
            "sensor_curvature": float(np.abs(np.diff(sensors, 2)).max() * 99**2)}


# ------------------------------------------------------------------ table and report


def _number(x):
    x = float(x)
    return x if math.isfinite(x) else None


def stability_table(methods, t=TIMES, cases=None):
    """Run methods on every extreme case and record what they return.

    Args:
        methods: dict name -> callable ``method(V, t) -> (q, p)`` taking sensor values of
            shape (N, 100) (float64, at :data:`SENSORS`) and times (M,), returning arrays
            of shape (N, M). Each case is passed as a batch of one.
        t: query times, shape (M,).
        cases: names of :data:`EXTREME_CASES` to run (default: all).

    Returns:
        JSON-serialisable dict ``{case: {method: entry}}``, entry a dict with ``finite``
        (bool: every q and p finite), ``L_tot`` (against :func:`extreme_reference`),
        ``energy_error`` (max over t of ``|p²/2 + V(q) - V0|`` on the true potential; None
        when not finite), ``warnings`` (list of "Category: message") and ``error`` (None,
        or "Type: message" of an exception the method raised, which is not propagated).

    Example:
        >>> from nh_operators import integrate_sensors
        >>> table = stability_table({"rk4_16": lambda V, t: integrate_sensors(V, t, "rk4", 16)},
        ...                         cases=["near_flat"])
        >>> table["near_flat"]["rk4_16"]["L_tot"] < 1e-20
        True
    """
    t = np.asarray(t, dtype=np.float64)
    potentials = extreme_potentials()
    table = {}
    for case in (list(EXTREME_CASES) if cases is None else cases):
        pot = potentials[case]
        V = pot.V(SENSORS)[None, :]
        q_ref, p_ref = extreme_reference(case, t)
        row = {}
        for name, method in methods.items():
            entry = {"finite": False, "L_tot": None, "energy_error": None, "warnings": [],
                     "error": None}
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    q, p = method(V.copy(), t)
                except Exception as exc:  # recorded in the table: a method may refuse
                    entry["error"] = f"{type(exc).__name__}: {exc}"
            if entry["error"] is None:
                q = np.asarray(q, dtype=np.float64).reshape(t.size)
                p = np.asarray(p, dtype=np.float64).reshape(t.size)
                entry["finite"] = bool(np.all(np.isfinite(q)) and np.all(np.isfinite(p)))
                with np.errstate(all="ignore"):
                    entry["L_tot"] = _number(loss_per_sample(q, p, q_ref, p_ref)["L_tot"])
                    entry["energy_error"] = _number(energy_error(q, p, pot))
            entry["warnings"] = sorted({f"{w.category.__name__}: {w.message}" for w in caught})
            row[name] = entry
        table[case] = row
    return table


def _cell(entry, key):
    if entry["error"] is not None:
        return "error"
    value = "non-finite" if entry[key] is None else f"{entry[key]:.1e}"
    return value + (" ⚠" if entry["warnings"] else "")


def stability_markdown(table):
    """The report section on stability at the extremes, from :func:`stability_table`.

    Args:
        table: the dict :func:`stability_table` returns (or its JSON).

    Returns:
        Markdown text: the cases with their measured properties, the thresholds, a table
        of L_tot and one of energy errors (⚠ marks a warning), and the warnings raised.
    """
    potentials = extreme_potentials()
    cases = list(table)
    methods = list(dict.fromkeys(m for case in cases for m in table[case]))
    rk4 = RESOLUTION_FRACTION * STABILITY_LIMITS["rk4"]
    lines = [
        "## Stability at the extremes", "",
        "Five bounded potentials far from the paper's generator, given to every method "
        "through their 100 sensor values; L_tot is against the exact trajectory (or DOP853 "
        "at 1e-13), the energy error max_t |p²/2 + V(q) − 2| is on the true potential.", "",
    ]
    for case in cases:
        props = case_properties(potentials[case])
        lines.append(f"- **{case}**: {EXTREME_CASES[case]} (V'(0) = {props['dV0']:.3g}, "
                     f"min V = {props['min_V']:.3g}).")
    lines += [
        "", "Warnings: the fixed-step solvers raise `ResolutionWarning` when "
        f"h·sqrt(max|V''|) exceeds {RESOLUTION_FRACTION:g} of the method's linear stability "
        f"limit (RK4: {rk4:.3g}; the generator's potentials reach 1.23 at one RK4 step per "
        "output interval) and name the substeps that suffice, and on a formula whose force "
        "jumps. `domain_violations` explains why sensor values are outside the generator's "
        "range (neural methods warn with `OutOfDomainWarning`). Nothing computed from 100 "
        "sensors can tell whether they resolve a wall narrower than their spacing.", "",
    ]
    for key, title in (("L_tot", "L_tot"), ("energy_error", "Energy error")):
        lines += [f"| {title} | " + " | ".join(methods) + " |",
                  "|---|" + "---:|" * len(methods)]
        for case in cases:
            cells = [_cell(table[case][m], key) if m in table[case] else "" for m in methods]
            lines.append(f"| {case} | " + " | ".join(cells) + " |")
        lines.append("")
    notes = sorted({(m, w) for case in cases for m, e in table[case].items()
                    for w in e["warnings"] + ([e["error"]] if e["error"] else [])})
    if notes:
        lines.append("Warnings and errors raised (first occurrence per method):")
        lines.append("")
        seen = set()
        for method, text in notes:
            kind = text.split(":")[0]
            if (method, kind) not in seen:
                seen.add((method, kind))
                lines.append(f"- `{method}`: {text}")
        lines.append("")
    return "\n".join(lines)
