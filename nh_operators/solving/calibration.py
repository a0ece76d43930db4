"""Calibrate a shipped model for :func:`~nh_operators.solve`: its estimate's factor and
the costs that ``method="auto"`` weighs (``nh-operators calibrate``).

The calibration set must be labelled potentials from neither the training set (seed
8407) nor the test set (seed 42); the shipped calibrations use
``nh-operators generate --size 2000 --seed 2718``. The timings are medians on the
machine that calibrates (recorded in the file): ``auto`` compares them only with each
other, so a faster machine shifts both alike.
"""

import json
import time
import warnings

import numpy as np

from .._constants import SENSORS, TIMES
from ..potentials import PHYSICAL_POTENTIALS
from ..training import write_atomic
from .auto_solve import _model, solve
from .catalog import CALIBRATION
from .costs import SHORT_HORIZON
from .acceptance import CONFIDENCE, SENSOR_FAMILIES, bin_factors, calibrated, upper_quantile
from .refine import refines
from .samples import calibration_families

__all__ = ["calibrate_pretrained", "CLASSICAL_TOLS", "QUANTILE",
           "CONFIDENCE", "LIMITS"]

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
                lambda pot: solve(pot, times, tol=tol, method="rk4"), items)
                for tol in CLASSICAL_TOLS]
            for field, items in (("classical_seconds", pots),
                                 ("classical_seconds_sensors", sensors),
                                 ("classical_seconds_formula", formulas))
            for suffix, times in (("", TIMES), ("_short", short))}
    return _TIMINGS[key]


def calibrate_pretrained(name, dataset, *, other=None, n_timing=30, n_ood=600,
                         ood_seed=2719, quantile=QUANTILE, timings_only=False,
                         keep_timings=False, write=True):
    """Calibrate shipped model ``name`` and write its calibration file.

    The factor makes ``factor · raw`` at the asked times
    (:func:`~nh_operators.solving.estimate_at`) an upper bound of the true L_tot per
    call: it is the largest, over the families of :func:`calibration_families` whose
    inputs are exact potentials, of a bootstrap upper bound (confidence
    :data:`CONFIDENCE`) on the ``quantile`` of true / raw. The raw estimate is first
    order in the error, so samples are bounded per bin of raw (split at :data:`LIMITS`),
    each bin with its factor, never smaller than a lower bin's
    (:func:`~nh_operators.solving.calibrated`). Sensor values, whose truth is their
    spline's trajectory, get the same bound over the families of sensor values
    (:mod:`~nh_operators.solving.acceptance`).

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
        timings_only: keep the stored factor; measure the network's and the classical
            solve's times again (on a quiet machine: ``auto`` compares them).
        keep_timings: calibrate the factors again and keep the stored times (measured
            on a quiet machine), e.g. on a busy one.
        write: write ``weights/NAME/calibration.json`` (atomically).

    Returns:
        the calibration dict: ``limits``, ``factors`` (one per bin, over the families
        of exact potentials: :func:`bin_factors`), ``factor`` (the first bin's),
        ``factors_sensors`` (the same over the families of sensor values), each also
        ``_early`` (early calls) and, for a network that refines, ``_fine``, ``quantile``,
        ``confidence``, ``families`` (per family: drawn, admitted, median and largest
        true / raw, and per bin the count and the bounded quantile),
        ``estimate_over_true_median`` (in distribution),
        ``estimate_quantiles`` / ``L_quantiles`` (calibrated estimate and true L_tot on
        the in-distribution family, at ``probabilities``), ``neural_seconds``,
        ``classical_tols`` / ``classical_seconds`` (B-spline, sensors, formula; each also
        ``_short``, up to :data:`~.costs.SHORT_HORIZON`), their per-row costs inside
        ``solve_many`` (``neural_seconds_batched``, ``classical_seconds_batched``,
        ``classical_seconds_sensors_batched``) and ``device``.
    """
    from ..data import load_dataset
    from .catalog import reads_state, resolve_pretrained

    name = resolve_pretrained(name)
    if not hasattr(dataset, "V"):
        dataset = load_dataset(dataset)
    model = _model(name)
    if timings_only:  # keep the factor and families, measure the costs again
        result = dict(model.calibration)
        _timings(result, name, dataset, n_timing)
        return _written(result, name, model, write)
    fams = calibration_families(name, dataset, other=other, n_ood=n_ood, ood_seed=ood_seed)
    result = {"quantile": quantile, "confidence": CONFIDENCE, "dataset_checksum":
              dataset.checksum, "ood_seed": ood_seed, "limits": list(LIMITS),
              "families": {}, "initial_state": reads_state(name)}
    fine = refines(name)
    for fam, (true, raw, drawn, early, true_fine, raw_fine) in fams.items():
        ratio = true / np.maximum(raw, 1e-300)
        entry = {"drawn": drawn, "admitted": int(true.size)}
        if true.size:
            entry.update(ratio_median=float(np.median(ratio)), ratio_max=float(ratio.max()))
        # the estimate on the grid (calls of the whole orbit, early calls) and, for a
        # network that refines, on the finer grid (:mod:`.refine`; not for early calls)
        for key, calls, t_l, r_l in (("bins", ~early, true, raw),
                                     ("bins_early", early, true, raw),
                                     ("bins_fine", ~early & fine, true_fine, raw_fine)):
            entry[key] = []
            where = np.searchsorted(LIMITS, r_l, side="left")  # bin k: (limit k-1, limit k]
            for k in range(len(LIMITS) + 1):
                pick = (where == k) & calls
                cell = {"n": int(pick.sum())}
                if pick.any():
                    cell["bound"] = upper_quantile(t_l[pick] / np.maximum(r_l[pick], 1e-300),
                                                   quantile)
                entry[key].append(cell)
        result["families"][fam] = entry
    families = result["families"]
    sensor = set(SENSOR_FAMILIES.values())
    for suffix, pick in (("", lambda fam: fam not in sensor), ("_sensors", sensor.__contains__)):
        for calls in ("", "_early") + (("_fine",) if fine else ()):
            factors = bin_factors((f for fam, f in families.items() if pick(fam)),
                                  "bins" + calls)
            if factors is None:
                raise ValueError(f"{name}: no calibration sample for "
                                 f"factors{suffix}{calls} (no input inside the network's "
                                 "domain, or too few calls of that kind)")
            result["factors" + suffix + calls] = factors
    result["factor"] = result["factors"][0]
    true, raw, _, early, *_ = fams["in distribution"]
    n = int(true.size)
    true, raw = true[~early], raw[~early]  # what a call of the whole orbit is accepted on
    estimate = calibrated(raw, result)
    probabilities = [0.0, 0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.99, 1.0]
    for fam, (f_true, f_raw, _, f_early, *_) in fams.items():  # how often each is accepted
        if (~f_early).any():
            kind = "sensors" if fam in SENSOR_FAMILIES.values() else "exact"
            families[fam]["estimate_quantiles"] = [float(v) for v in np.quantile(
                calibrated(f_raw[~f_early], result, kind), probabilities)]
    result.update(n=n, probabilities=probabilities,
                  estimate_quantiles=[float(v) for v in np.quantile(estimate, probabilities)],
                  L_quantiles=[float(v) for v in np.quantile(true, probabilities)],
                  estimate_over_true_median=float(np.median(estimate / np.maximum(true,
                                                                                 1e-300))))
    if keep_timings:
        result.update({key: value for key, value in model.calibration.items()
                       if key.startswith(("neural_seconds", "classical_")) or key == "device"})
    else:
        _timings(result, name, dataset, n_timing)
    return _written(result, name, model, write)


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
    from .network_pass import _network_rows

    return lambda V: _network_rows(name, V, row_source(V, "sensors"), "sensors", TIMES,
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
                lambda rows: solve_many(rows, TIMES, tol=tol, method="rk4"), items, 1)
                for tol in CLASSICAL_TOLS]
            for field, items in (("classical_seconds_sensors_batched", sensors),
                                 ("classical_seconds_batched", bsplines))}
    return _TIMINGS[key]


def _written(result, name, model, write):
    from .catalog import WEIGHTS

    if write:
        path = WEIGHTS / name / CALIBRATION
        write_atomic(path, (json.dumps(result, indent=2) + "\n").encode())
        model.calibration = result
    return result
