"""Calibrate a shipped model for :func:`~nh_operators.solve`: its estimate's factor and
the costs that ``method="auto"`` weighs (``nh-operators calibrate``).

The calibration set must be labelled potentials from neither the training set (seed
8407) nor the test set (seed 42); the shipped calibrations use
``nh-operators generate --size 2000 --seed 2718``. The timings are medians on the
machine that calibrates (recorded in the file): ``auto`` compares them only with each
other, so a faster machine shifts both alike.
"""

from __future__ import annotations

import time
import warnings
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from .._constants import SENSORS, TIMES
from ..potentials import PHYSICAL_POTENTIALS
from ..training import write_atomic
from .acceptance import CONFIDENCE, SENSOR_FAMILIES, bin_factors, upper_quantile
from .auto_solve import solve
from .calibration import Calibration, costs_from_v1, factors_from_v1
from .costs import SHORT_HORIZON
from .loader import load
from .refine import refines
from .samples import calibration_families

__all__ = [
    "CLASSICAL_TOLS",
    "CONFIDENCE",
    "LIMITS",
    "QUANTILE",
    "Measure",
    "calibrate_factors",
    "calibrate_pretrained",
    "measure_costs",
]

#: The quantile of true / raw estimate that the factor bounds (with :data:`CONFIDENCE`).
QUANTILE = 0.999

#: Raw estimates are calibrated in bins split at these values (L_tot units; 1e-3 is an
#: RMS error of 3 % of the orbit's size): the estimate is first order in the error, so
#: its ratio to the truth spreads more as the error grows, and each bin gets its factor.
LIMITS = (1e-3, 1e-2)

#: Tolerances at which the classical solve's time is measured.
CLASSICAL_TOLS = [10.0 ** -k for k in range(1, 13)]


def _median_seconds(fn, items, repeats=3):
    times = []
    for item in items:
        best = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn(item)
            best = min(best, time.perf_counter() - t0)
        times.append(best)
    return float(np.median(times))


_TIMINGS = {}


def _classical_timings(key, pots):
    """The classical solve's median seconds at each of :data:`CLASSICAL_TOLS` on ``pots``
    (exact), their sensor values and three smooth formulas, on the whole grid and (the
    ``_short`` fields) on its times up to :data:`~.costs.SHORT_HORIZON`, each a call of
    :func:`~nh_operators.solve` as a user makes it; measured once per process and dataset
    (``key``), as they do not depend on the network."""
    if key not in _TIMINGS:
        sensors = [pot.V(SENSORS) for pot in pots]
        formulas = list(PHYSICAL_POTENTIALS.values())[:3]  # smooth: SHO, double well, Morse
        short = TIMES[TIMES <= SHORT_HORIZON + 1e-12]
        _TIMINGS[key] = {
            field + suffix: [_median_seconds(
                lambda pot, times=times, tol=tol: solve(pot, times, tol=tol, method="rk4"),
                items)
                for tol in CLASSICAL_TOLS]
            for field, items in (("classical_seconds", pots),
                                 ("classical_seconds_sensors", sensors),
                                 ("classical_seconds_formula", formulas))
            for suffix, times in (("", TIMES), ("_short", short))}
    return _TIMINGS[key]


class Measure(str, Enum):
    """What :func:`calibrate_pretrained` measures again; the rest is kept from the
    network's current calibration."""

    ALL = "all"          #: factors and costs
    FACTORS = "factors"  #: the factors (keep the costs, e.g. measured on a quiet machine)
    COSTS = "costs"      #: the costs (keep the factors; measure on a quiet machine)


#: The levels of the stored estimate quantiles.
PROBABILITIES = [0.0, 0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.99, 1.0]


def calibrate_pretrained(name: str, dataset: Any, *, other: Any = None, n_timing: int = 30,
                         n_ood: int = 600, ood_seed: int = 2719, quantile: float = QUANTILE,
                         measure: Measure | str = Measure.ALL,
                         out: str | Path | None = None) -> Calibration:
    """Calibrate shipped model ``name``: :func:`calibrate_factors` and
    :func:`measure_costs`, as one :class:`~nh_operators.solving.calibration.Calibration`.

    Args:
        name: a shipped model (:func:`~nh_operators.available_pretrained`).
        dataset: labelled :class:`~nh_operators.data.Dataset` of the model's own
            distribution, from neither its training nor its test seed, or its path.
        other: potentials of the other generator (a batched
            :class:`~nh_operators.BoundedPotential`), or None.
        n_timing: potentials timed (batch 1; best of 3 each, median over them).
        n_ood, ood_seed: out-of-distribution potentials (a seed other than the
            contract tests').
        quantile: the quantile of true / raw bounded.
        measure: :class:`Measure` (or its value): what to measure again; the rest is
            kept from the model's current calibration.
        out: a file to write the calibration to (atomically), or None. Never the
            installed package unless you name its file: to use a calibration written
            elsewhere, :func:`~nh_operators.solving.loader.with_calibration`.

    Returns:
        the :class:`~nh_operators.solving.calibration.Calibration`.

    Raises:
        ValueError: an unknown ``measure``; a model without a calibration to keep
            from; no calibration sample for a factor table.
    """
    from ..data import load_dataset
    from .catalog import resolve_pretrained

    measure = Measure(measure)
    name = resolve_pretrained(name)
    if not hasattr(dataset, "V"):
        dataset = load_dataset(dataset)
    current = load(name).calibration
    if measure is not Measure.ALL and current is None:
        raise ValueError(f"{name} has no calibration to keep parts of: measure='all'")
    kept = current.to_json() if current is not None else {}
    data = ({k: v for k, v in kept.items() if k != "costs"} if measure is Measure.COSTS
            else calibrate_factors(name, dataset, other=other, n_ood=n_ood,
                                   ood_seed=ood_seed, quantile=quantile))
    data["costs"] = (kept["costs"] if measure is Measure.FACTORS
                     else measure_costs(name, dataset, n_timing))
    calibration = Calibration.from_json(data)
    if out is not None:
        write_atomic(Path(out), calibration.dumps().encode())
    return calibration


def calibrate_factors(name: str, dataset: Any, *, other: Any = None, n_ood: int = 600,
                      ood_seed: int = 2719, quantile: float = QUANTILE) -> dict[str, Any]:
    """The factors of shipped model ``name`` and how often its estimate is accepted.

    The factors make ``factors[k] · raw`` at the asked times
    (:func:`~nh_operators.solving.estimate_at`) an upper bound of the true L_tot per
    call: each is the largest, over the families of :func:`calibration_families` of one
    input kind, of a bootstrap upper bound (confidence :data:`CONFIDENCE`) on the
    ``quantile`` of true / raw. The raw estimate is first order in the error, so
    samples are bounded per bin of raw (split at :data:`LIMITS`), each bin with its
    factor, never smaller than a lower bin's. Sensor values, whose truth is their
    spline's trajectory, get the same bound over the families of sensor values.

    Returns:
        everything but the ``costs`` of a calibration in format 2
        (:meth:`~nh_operators.solving.calibration.Calibration.to_json`): ``limits``,
        ``factors`` (exact and sensors; plain, early and, for a network that refines,
        fine), ``families``, ``probabilities``, ``estimate_quantiles`` and ``info``
        (``quantile``, ``confidence``, ``n``, ``L_quantiles``,
        ``estimate_over_true_median``, the dataset's checksum).
    """
    from .catalog import reads_state

    fams = calibration_families(name, dataset, other=other, n_ood=n_ood, ood_seed=ood_seed)
    fine = refines(name)
    result: dict[str, Any] = {"quantile": quantile, "confidence": CONFIDENCE,
                              "dataset_checksum": dataset.checksum,
                              "dataset_draw": dataset.generator.get("draw", 1),
                              "ood_seed": ood_seed,
                              "limits": list(LIMITS), "initial_state": reads_state(name),
                              "families": {fam: _family_bounds(*sample, quantile, fine)
                                           for fam, sample in fams.items()}}
    result.update(_factor_tables(name, result["families"], fine))
    result.update(_acceptance(fams, result))
    return factors_from_v1(result)


def _family_bounds(true: np.ndarray, raw: np.ndarray, drawn: int, early: np.ndarray,
                   true_fine: np.ndarray, raw_fine: np.ndarray, quantile: float,
                   fine: bool) -> dict[str, Any]:
    """One family's entry: counts, median and largest true / raw, and per bin of raw the
    count and the bounded ``quantile`` of true / raw, for calls of the whole orbit
    (``bins``), early calls (``bins_early``) and the finer look (``bins_fine``)."""
    ratio = true / np.maximum(raw, 1e-300)
    entry: dict[str, Any] = {"drawn": drawn, "admitted": int(true.size)}
    if true.size:
        entry.update(ratio_median=float(np.median(ratio)), ratio_max=float(ratio.max()))
    for key, calls, t_l, r_l in (("bins", ~early, true, raw),
                                 ("bins_early", early, true, raw),
                                 ("bins_fine", ~early & fine, true_fine, raw_fine)):
        entry[key] = []
        where = np.searchsorted(LIMITS, r_l, side="left")  # bin k: (limit k-1, limit k]
        for k in range(len(LIMITS) + 1):
            pick = (where == k) & calls
            cell: dict[str, Any] = {"n": int(pick.sum())}
            if pick.any():
                cell["bound"] = upper_quantile(t_l[pick] / np.maximum(r_l[pick], 1e-300),
                                               quantile)
            entry[key].append(cell)
    return entry


def _factor_tables(name: str, families: dict[str, Any], fine: bool) -> dict[str, list]:
    """``factors[_sensors][_early|_fine]`` over the exact and the sensor families."""
    sensor = set(SENSOR_FAMILIES.values())
    out = {}
    for suffix, pick in (("", lambda fam: fam not in sensor), ("_sensors", sensor.__contains__)):
        for calls in ("", "_early") + (("_fine",) if fine else ()):
            factors = bin_factors((f for fam, f in families.items() if pick(fam)),
                                  "bins" + calls)
            if factors is None:
                raise ValueError(f"{name}: no calibration sample for "
                                 f"factors{suffix}{calls} (no input inside the network's "
                                 "domain, or too few calls of that kind)")
            out["factors" + suffix + calls] = factors
    return out


def _apply(factors: list[float], raw: np.ndarray) -> np.ndarray:
    return np.asarray(factors)[np.searchsorted(LIMITS, raw, side="left")] * raw


def _acceptance(fams: dict[str, tuple], result: dict[str, Any]) -> dict[str, Any]:
    """How often each family's calibrated estimate meets a tolerance (calls of the whole
    orbit), and the in-distribution summary (in place for the families)."""
    true, raw, _, early, *_ = fams["in distribution"]
    n = int(true.size)
    true, raw = true[~early], raw[~early]  # what a call of the whole orbit is accepted on
    estimate = _apply(result["factors"], raw)
    for fam, (_, f_raw, _, f_early, *_) in fams.items():  # how often each is accepted
        if (~f_early).any():
            key = "factors_sensors" if fam in SENSOR_FAMILIES.values() else "factors"
            result["families"][fam]["estimate_quantiles"] = [float(v) for v in np.quantile(
                _apply(result[key], f_raw[~f_early]), PROBABILITIES)]
    return {"n": n, "probabilities": PROBABILITIES,
            "estimate_quantiles": [float(v) for v in np.quantile(estimate, PROBABILITIES)],
            "L_quantiles": [float(v) for v in np.quantile(true, PROBABILITIES)],
            "estimate_over_true_median": float(np.median(estimate / np.maximum(true,
                                                                              1e-300)))}


def measure_costs(name: str, dataset: Any, n_timing: int = 30) -> dict[str, Any]:
    """Median seconds of one network solve and of the classical solves, and the per-row
    seconds of the same in ``solve_many``, on this machine (recorded in ``device``).

    Returns:
        the ``costs`` of a calibration in format 2.
    """
    result: dict[str, Any] = {}
    _timings(result, name, dataset, n_timing)
    return costs_from_v1(result)


def _timings(result, name, dataset, n_timing, n_batched=(1000, 300, 50)):
    """Median seconds of one network solve and of the classical solves, and the per-row
    seconds of the same in ``solve_many`` (in place).

    ``n_batched``: rows of the batched network timing (sensor values), of the batched
    classical timing on sensor values, and on the exact B-splines.
    """
    from .._backend import single_threaded
    from ..evaluation import device_info

    pots = [dataset.potential(i) for i in range(min(n_timing, len(dataset)))]
    with warnings.catch_warnings():  # the network's whole call, as a user makes it
        warnings.simplefilter("ignore")
        result["neural_seconds"] = _median_seconds(
            lambda pot: solve(pot, TIMES, method=name), pots)
    result["classical_tols"] = CLASSICAL_TOLS
    result.update(_classical_timings(dataset.checksum, tuple(pots)))
    with single_threaded():
        result["neural_seconds_batched"] = _per_row_seconds(
            _batched_network(name), dataset.V[:n_batched[0]])
        result.update(_batched_classical_timings(dataset, n_batched[1:]))
    result["device"] = device_info("cpu")


def _per_row_seconds(fn, rows, repeats=2):
    """Best of ``repeats`` calls of ``fn(rows)`` after a warm-up, per row."""
    fn(rows[:10])
    return _median_seconds(fn, [rows], repeats) / len(rows)


def _batched_network(name):
    """What ``solve_many`` does with a network's rows of sensor values: predict, estimate
    at the times (with the sensors' spline, which the classical rows share)."""
    from ..solvers.rows import row_source
    from .kinds import InputKind
    from .network_pass import network_rows

    kind = InputKind.SENSORS
    return lambda V: network_rows(name, V, row_source(V, kind.information), kind, TIMES,
                                  np.arange(len(V)))


def _batched_classical_timings(dataset, sizes):
    """Per-row seconds of ``solve_many(method="rk4")`` at each of :data:`CLASSICAL_TOLS`
    on sensor values and on the exact B-splines; once per process and dataset."""
    from .many import solve_many

    key = ("batched", dataset.checksum, tuple(sizes))
    if key not in _TIMINGS:
        sensors, bsplines = dataset.V[:sizes[0]], dataset.potentials()[:sizes[1]]
        _TIMINGS[key] = {
            field: [_per_row_seconds(
                lambda rows, tol=tol: solve_many(rows, TIMES, tol=tol, method="rk4"),
                items, 1)
                for tol in CLASSICAL_TOLS]
            for field, items in (("classical_seconds_sensors_batched", sensors),
                                 ("classical_seconds_batched", bsplines))}
    return _TIMINGS[key]
