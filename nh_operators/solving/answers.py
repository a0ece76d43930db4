"""What an answer of :func:`~nh_operators.solve` or :func:`~nh_operators.solve_many` is
measured against (:class:`Truth`), and what each shipped network was for one call
(:class:`Candidate`).

The promise, exactly: an answer with ``converged=True`` has an estimated L_tot ≤ tol,
the estimate measured against ``truth.reference``:

* the classical path (``truth.confidence == 1.0``): the solver's own step-doubling
  estimate, a bound by construction (with a safety factor across kinks), not a statistic;
  no answer is returned over tol without ``converged=False`` and a ``RuntimeWarning``;
* a network (``truth.confidence`` = its calibrated quantile, 0.999 for every shipped one):
  its calibrated estimate bounds the true L_tot on that share of inputs like its
  calibration families (the bound itself a bootstrap one at 95 % confidence); about 1 in
  1,000 accepted answers may exceed tol.

``truth.reference`` is the exact potential for names, formulas, callables and
B-splines, and the spline through the sensor values for sensor values: their estimate
(and promise) is against that spline's trajectory, which can be far from the trajectory
of a potential the values were sampled from (the information limit of 100 sensors).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from enum import Enum

import numpy as np

from .._constants import TIMES
from .calibration import Calibration
from .catalog import shipped_names
from .kinds import InputKind
from .loader import load
from .ranking import SAVING

__all__ = ["MAX_SUBSTEPS", "Candidate", "Reference", "Truth", "Verdict", "candidates",
           "row_truths", "truth_of"]

#: The classical solver's cap on substeps per output interval in ``solve`` and
#: ``solve_many``: 2¹³, where :func:`~nh_operators.solve_classical` stops at 2¹². MFF's
#: kink needs 8,192 on :data:`TIMES` from rest at :data:`~nh_operators.DEFAULT_TOL` (the
#: other shipped physical potentials 32), so the default is certified on every one of
#: them there; at other times or states a kink may still miss it, and the answer then
#: says ``converged=False``. A smooth potential never comes near the cap; a tol it
#: cannot reach costs about twice the cap's last level (a formula's first solve runs in
#: Python: MFF's then takes seconds).
MAX_SUBSTEPS = 2**13


class Reference(str, Enum):
    """What an estimate is measured against.

    Example:
        >>> Reference.SPLINE.value
        'sensor spline'
    """

    EXACT = "exact potential"
    SPLINE = "sensor spline"


@dataclass(frozen=True)
class Truth:
    """What an answer's estimate (and its promise) is measured against.

    Attributes:
        reference: the exact potential's trajectory, or the sensor spline's.
        confidence: 1.0 for the classical solver (its estimate is a bound by
            construction); for a network, the calibrated quantile its estimate bounds
            (0.999); nan for a network whose calibration records none (or that has
            none: its estimate is then the raw one).

    Example:
        >>> str(Truth(Reference.SPLINE, 0.999))
        'sensor spline, 99.9 % quantile'
    """

    reference: Reference
    confidence: float = 1.0

    @property
    def certain(self) -> bool:
        """Whether the estimate is a bound on every answer, not on a quantile."""
        return self.confidence == 1.0

    def __str__(self) -> str:
        if self.certain:
            return self.reference.value
        if np.isnan(self.confidence):
            return f"{self.reference.value}, no recorded quantile"
        return f"{self.reference.value}, {100 * self.confidence:g} % quantile"


def truth_of(kind: InputKind, network: str | None = None) -> Truth:
    """The truth of an answer on an input of ``kind``, by the classical solver
    (``network=None``) or by shipped network ``network`` (its calibrated quantile).

    Example:
        >>> truth_of(InputKind.FORMULA)
        Truth(reference=<Reference.EXACT: 'exact potential'>, confidence=1.0)
    """
    reference = Reference.EXACT if kind.exact else Reference.SPLINE
    if network is None:
        return Truth(reference)
    cal = load(network).calibration
    quantile = None if cal is None else cal.info.get("quantile")
    return Truth(reference, float("nan") if quantile is None else float(quantile))


def row_truths(kind: InputKind, methods: np.ndarray, neural: np.ndarray) -> np.ndarray:
    """Each row's :class:`Truth` in a ``solve_many`` call on inputs of ``kind``.

    Args:
        kind: the input kind of every row.
        methods: (N,) method names.
        neural: (N,) bool, rows a network answered.

    Returns:
        (N,) object array (one shared object per method).
    """
    out = np.empty(len(methods), dtype=object)
    out[:] = [truth_of(kind)] * len(methods)
    if not neural.any():
        return out
    for name in np.unique(methods[neural]).tolist():
        out[neural & (methods == name)] = truth_of(kind, str(name))
    return out


class Verdict(str, Enum):
    """What became of a network in one :func:`~nh_operators.solve` call."""

    ANSWERED = "answered"
    REJECTED = "its estimate missed tol"
    NOT_TRIED = "not tried: a cheaper one was chosen"
    OUTSIDE_DOMAIN = "input outside its domain"
    OUTSIDE_TIMES = "times outside [0, 2]"
    NOT_CHEAPER = "not expected to be cheaper"
    UNCALIBRATED = "not calibrated"


@dataclass(frozen=True)
class Candidate:
    """One shipped network weighed by one ``solve(..., method="auto", tol=...)`` call.

    Attributes:
        name: the shipped name.
        verdict: what became of it.
        share: the share of its calibration set whose calibrated estimate met tol
            (None when not calibrated).
        expected_seconds: its expected cost, rejections included (None: not calibrated).
        classical_seconds: the classical solve's cost it was weighed against.
    """

    name: str
    verdict: Verdict
    share: float | None = None
    expected_seconds: float | None = None
    classical_seconds: float | None = None


def candidates(tol: float, kind: InputKind, states: bool, horizon: float | None,
               t: np.ndarray, chosen: str | None,
               accepted: bool | None = None) -> tuple[Candidate, ...]:
    """Every shipped network of the call's group (at rest, or reading a starting state),
    with its verdict; the ones expected to be cheaper first, cheapest first.

    ``chosen`` is the network :func:`~nh_operators.solving.ranking.choose` returned
    (None: none), ``accepted`` whether its estimate met tol. ``choose`` tries the
    cheaper ones in order, so the ones before ``chosen`` did not hold the input in their
    domain and the ones after it were not tried.

    Args:
        tol: the tolerance.
        kind: the input kind.
        states: the networks that read a starting state, else the others.
        horizon: :func:`~nh_operators.solving.costs.horizon_key` of the times.
        t: (M,) the asked times.
        chosen: the network tried, or None.
        accepted: whether its estimate met tol.

    Returns:
        tuple of :class:`Candidate`.
    """
    names = shipped_names()
    table = _table(tol, InputKind(kind), states, horizon, names,
                   tuple(load(name).calibration for name in names))
    cheaper = [row for row in table if row[1]]
    out_of_times = bool(np.max(t) > TIMES[-1] + 1e-12)
    seen_chosen = False
    result = []
    for name, _, share, expected, classical in cheaper:
        if name == chosen:
            verdict, seen_chosen = (Verdict.ANSWERED if accepted else Verdict.REJECTED), True
        elif seen_chosen:
            verdict = Verdict.NOT_TRIED
        else:
            verdict = Verdict.OUTSIDE_TIMES if out_of_times else Verdict.OUTSIDE_DOMAIN
        result.append(Candidate(name, verdict, share, expected, classical))
    for name, _, share, expected, classical in (row for row in table if not row[1]):
        verdict = Verdict.UNCALIBRATED if share is None else Verdict.NOT_CHEAPER
        result.append(Candidate(name, verdict, share, expected, classical))
    return tuple(result)


@functools.lru_cache(maxsize=256)
def _table(tol: float, kind: InputKind, states: bool, horizon: float | None,
           names: tuple[str, ...], calibrations: tuple[Calibration | None, ...]) -> tuple:
    """(name, cheaper, share, expected, classical) per network of the group, the cheaper
    ones by expected cost (keyed on the calibration objects, as the ranking is)."""
    rows = []
    for name, cal in zip(names, calibrations, strict=True):
        if load(name).reads_state != states:
            continue
        if cal is None:
            rows.append((name, False, None, None, None))
            continue
        expected, share, t_cls = cal.expected_seconds(tol, kind, batched=False,
                                                      horizon=horizon)
        rows.append((name, bool(expected < SAVING * t_cls), float(share), float(expected),
                     float(t_cls)))
    return tuple(sorted(rows, key=lambda r: (not r[1], r[3] if r[1] else 0.0)))
