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

import numpy as np

from .._constants import SENSORS, TIMES
from .._metrics import loss_per_sample
from ..potentials import PHYSICAL_POTENTIALS
from ..solvers import adaptive_solve
from ..training import write_atomic
from .auto_solve import _model, neural_raw, neural_solve
from .catalog import CALIBRATION
from .costs import SHORT_HORIZON
from .acceptance import (CONFIDENCE, EARLY_HORIZON, SENSOR_FAMILIES, bin_factors, calibrated,
                         upper_quantile)
from .estimate import sensor_force

__all__ = ["calibrate_pretrained", "calibration_families", "CLASSICAL_TOLS", "QUANTILE",
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
    ``_short`` fields) on its times up to :data:`~.costs.SHORT_HORIZON`; measured once
    per process and dataset (``key``), as they do not depend on the network."""
    if key not in _TIMINGS:
        sensors = [pot.V(SENSORS) for pot in pots]
        formulas = list(PHYSICAL_POTENTIALS.values())[:3]  # smooth: SHO, double well, Morse
        short = TIMES[TIMES <= SHORT_HORIZON + 1e-12]
        _TIMINGS[key] = {
            field + suffix: [_median_seconds(
                lambda pot: adaptive_solve(pot, information, times, tol, "rk4"), items)
                for tol in CLASSICAL_TOLS]
            for field, items, information in (
                ("classical_seconds", pots, "exact V"),
                ("classical_seconds_sensors", sensors, "sensors"),
                ("classical_seconds_formula", formulas, "exact V"))
            for suffix, times in (("", TIMES), ("_short", short))}
    return _TIMINGS[key]


def _asked_times(rng):
    """A random call's times: one time (30 %) or 2–100 uniform times in [0, h], h = 2
    for a third of the calls, log-uniform in [:data:`EARLY_HORIZON`, 2] for a third and
    in [0.02, :data:`EARLY_HORIZON`] for the last third (early calls, calibrated apart)."""
    m = 1 if rng.random() < 0.3 else int(rng.integers(2, 101))
    lo, hi = ((TIMES[-1], TIMES[-1]), (EARLY_HORIZON, TIMES[-1]),
              (0.02, EARLY_HORIZON))[int(rng.integers(3))]
    return rng.uniform(0.0, float(np.exp(rng.uniform(np.log(lo), np.log(hi)))), m)


def _states(values, n, rng):
    """Starting states stratified by energy (:func:`~nh_operators.solvers.energy_states`)
    of n rows whose V at row i's positions is ``values(x)``: (q0, p0), each (n,)."""
    from ..solvers import STATE_UNIFORMS, energy_states

    q0, p0, _ = energy_states(values, rng.random((n, STATE_UNIFORMS)))
    return q0, p0


def _batch_ratios(name, pots, sensors, rng, group=20, states=None):
    """true L_tot and raw estimate of model ``name`` on the rows of a batched B-spline
    ``pots`` inside its domain, each group of rows at one random set of asked times;
    ``sensors``: the input is the sensor values (force and truth: their spline; ``pots``
    may then be the sensor values themselves, (N, 100));
    ``states``: the rows' starting states (q0, p0), for a network that reads one."""
    from ..models import predict
    from ..potentials import in_domain
    from ..solvers import integrate_sensors, reference_solve
    from ..solvers.rows import row_source
    from .catalog import network_domain
    from .estimate import estimate_at

    from .auto_solve import network_input

    V = pots if isinstance(pots, np.ndarray) else pots.V(SENSORS)
    keep = np.flatnonzero(in_domain(V, network_domain(name)))
    net = _model(name).net
    q0s, p0s = (np.zeros(len(V)), np.zeros(len(V))) if states is None else states
    true, raw, early = [], [], []
    for lo in range(0, keep.size, group):
        rows = keep[lo:lo + group]
        t = _asked_times(rng)
        early.append(np.full(rows.size, t.max() <= EARLY_HORIZON))
        state = {"q0": q0s[rows], "p0": p0s[rows]}
        q, p = predict(net, network_input(name, V[rows], **state), TIMES)
        if sensors:
            q_ref, p_ref = integrate_sensors(V[rows], t, substeps=512, check_resolution=False,
                                             **state)
            force = sensor_force(V[rows])
        else:
            sub = type(pots)(pots.control_q[rows], pots.control_V[rows])
            q_ref, p_ref = reference_solve(sub, t, **state)
            src = row_source(sub, "exact V")
            force = (src.values_at, lambda x, src=src: -src.forces_at(x))
        qa, pa, r = estimate_at(q, p, *force, t, **state)
        true.append(loss_per_sample(qa, pa, q_ref, p_ref)["L_tot"])
        raw.append(r)
    if not true:
        return np.zeros(0), np.zeros(0), 0, np.zeros(0, dtype=bool)
    return (np.concatenate(true), np.concatenate(raw), int(V.shape[0]),
            np.concatenate(early))


def _ood_ratios(name, n, seed, rng, states=False):
    """Like :func:`_batch_ratios` on :func:`~nh_operators.potentials.ood_potentials`
    (``states``: each from a state stratified by energy)."""
    from ..potentials import in_domain, ood_potentials
    from ..solvers import reference_solve
    from .catalog import network_domain

    true, raw, early = [], [], []
    for pot in ood_potentials(n, seed):
        if not in_domain(pot.V(SENSORS), network_domain(name)):
            continue
        t = _asked_times(rng)
        early.append(t.max() <= EARLY_HORIZON)
        state = {}
        if states:
            q0, p0 = _states(lambda x, pot=pot: pot.V(x), 1, rng)
            state = {"q0": float(q0[0]), "p0": float(p0[0])}
        q, p, r = neural_raw(name, pot, "exact V", t, **state)
        true.append(float(loss_per_sample(q, p, *reference_solve(pot, t, **state))["L_tot"]))
        raw.append(r)
    return np.array(true), np.array(raw), n, np.array(early, dtype=bool)


def calibration_families(name, dataset, *, other=None, n_ood=600, ood_seed=2719,
                         n_sensors=None, seed=0):
    """The samples that calibrate model ``name``: {family: (true, raw, drawn, early)},
    ``early`` marking the samples of calls whose latest time is at most
    :data:`EARLY_HORIZON`.

    Exact potentials: ``in distribution`` (the dataset's), ``other distribution``
    (``other``, a batched B-spline of the other generator, if given), ``out of
    distribution`` (:func:`~nh_operators.potentials.ood_potentials`); the same as sensor
    values (:data:`~nh_operators.solving.acceptance.SENSOR_FAMILIES`: force and truth
    from their spline; ``sensors``: the first ``n_sensors``, default all), each row at
    :data:`SENSOR_PASSES` sets of times. Each only where the network's domain admits it
    (what ``auto`` would hand it), at random asked times (:func:`_asked_times`). A network
    that reads a state starts from the dataset's own or, elsewhere, from states
    stratified by energy (:func:`~nh_operators.solvers.energy_states`).
    """
    from ..potentials import ood_potentials
    from ..solvers.rows import row_source
    from .catalog import reads_state

    rng = np.random.default_rng(seed)
    pots = dataset.potentials()
    states = reads_state(name)
    if states and getattr(dataset, "q0", None) is None:
        raise ValueError(f"{name} reads a starting state: calibrate it on a dataset with "
                         "states (nh-operators generate --states energy)")
    own = (dataset.q0, dataset.p0) if states else None
    out = {"in distribution": _batch_ratios(name, pots, False, rng, states=own)}
    if other is not None:
        drawn = _states(row_source(other, "exact V").values_at, len(other.control_q),
                        rng) if states else None
        out["other distribution"] = _batch_ratios(name, other, False, rng, states=drawn)
    if n_ood:
        out["out of distribution"] = _ood_ratios(name, n_ood, ood_seed, rng, states)
    head = slice(0, n_sensors)
    out["sensors"] = _sensor_family(name, dataset.V[head], rng, states,
                                    own and (own[0][head], own[1][head]))
    if other is not None:
        out[SENSOR_FAMILIES["other distribution"]] = _sensor_family(
            name, other.V(SENSORS), rng, states)
    if n_ood:
        V = np.stack([pot.V(SENSORS) for pot in ood_potentials(n_ood, ood_seed)])
        out[SENSOR_FAMILIES["out of distribution"]] = _sensor_family(name, V, rng, states)
    return out


#: Sets of asked times per row in a family of sensor values.
SENSOR_PASSES = 3


def _sensor_family(name, V, rng, states, own=None):
    """:func:`_batch_ratios` on sensor values V (N, 100), :data:`SENSOR_PASSES` times;
    ``states``: the rows' own (``own``) or drawn stratified by energy on their splines."""
    from ..solvers.rows import row_source

    V = np.asarray(V, dtype=np.float64)
    if states and own is None:
        own = _states(row_source(V, "sensors").values_at, len(V), rng)
    parts = [_batch_ratios(name, V, True, rng, states=own) for _ in range(SENSOR_PASSES)]
    true, raw, early = (np.concatenate([p[k] for p in parts]) for k in (0, 1, 3))
    return true, raw, len(V), early.astype(bool)


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
        ``factors_sensors`` (the same over the families of sensor values), ``quantile``,
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
    for fam, (true, raw, drawn, early) in fams.items():
        ratio = true / np.maximum(raw, 1e-300)
        entry = {"drawn": drawn, "admitted": int(true.size)}
        if true.size:
            entry.update(ratio_median=float(np.median(ratio)), ratio_max=float(ratio.max()))
        where = np.searchsorted(LIMITS, raw, side="left")  # bin k: (limit k-1, limit k]
        for key, calls in (("bins", ~early), ("bins_early", early)):
            entry[key] = []
            for k in range(len(LIMITS) + 1):
                pick = (where == k) & calls
                cell = {"n": int(pick.sum())}
                if pick.any():
                    cell["bound"] = upper_quantile(ratio[pick], quantile)
                entry[key].append(cell)
        result["families"][fam] = entry
    families = result["families"]
    sensor = set(SENSOR_FAMILIES.values())
    for suffix, pick in (("", lambda fam: fam not in sensor), ("_sensors", sensor.__contains__)):
        for calls in ("", "_early"):
            factors = bin_factors((f for fam, f in families.items() if pick(fam)),
                                  "bins" + calls)
            if factors is None:
                raise ValueError(f"{name}: no calibration input lies inside the network's "
                                 "domain")
            result["factors" + suffix + calls] = factors
    result["factor"] = result["factors"][0]
    true, raw, _, early = fams["in distribution"]
    n = int(true.size)
    true, raw = true[~early], raw[~early]  # what a call of the whole orbit is accepted on
    estimate = calibrated(raw, result)
    probabilities = [0.0, 0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.99, 1.0]
    for fam, (f_true, f_raw, _, f_early) in fams.items():  # how often each is accepted
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
    result["neural_seconds"] = _median_seconds(
        lambda pot: neural_solve(name, pot, "exact V", TIMES), pots)
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
    from .many import _network_rows

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
