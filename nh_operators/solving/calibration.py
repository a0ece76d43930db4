"""Calibrate a shipped model for :func:`~nh_operators.solve`: its estimate's factor and
the costs that ``method="auto"`` weighs (``nh-operators calibrate``).

The calibration set must be labelled potentials from neither the training set (seed
8407) nor the test set (seed 42); the shipped calibrations use
``nh-operators generate --size 2000 --seed 2718``. The timings are medians on the
machine that calibrates (recorded in the file): ``auto`` compares them only with each
other, so a faster machine shifts both alike.
"""

import functools
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
from .estimate import calibrate

__all__ = ["calibrate_pretrained", "CLASSICAL_TOLS"]

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


@functools.lru_cache(maxsize=4)
def _ood_cases(n, seed):
    """Out-of-distribution potentials with their references on TIMES."""
    from ..potentials import ood_potentials
    from ..solvers import reference_solve

    return [(pot, *reference_solve(pot, TIMES)) for pot in ood_potentials(n, seed)]


def ood_factor(name, n, seed, quantile):
    """The ``quantile`` of L_tot / (E + D) for model ``name`` on the out-of-distribution
    potentials (:mod:`nh_operators.potentials.ood`) inside its domain
    (:func:`~nh_operators.solving.catalog.network_domain`), i.e. those ``auto`` would
    give the network; returns (factor, how many)."""
    from ..potentials import in_domain
    from .catalog import network_domain

    ratios = []
    for pot, q_ref, p_ref in _ood_cases(n, seed):
        if not in_domain(pot.V(SENSORS), network_domain(name)):
            continue
        q, p, raw = neural_raw(name, pot, "exact V")
        true = float(loss_per_sample(q[0], p[0], q_ref, p_ref)["L_tot"])
        ratios.append(true / raw if raw > 0 else np.inf)
    return (float(np.quantile(ratios, quantile)) if ratios else 0.0), len(ratios)


def calibrate_pretrained(name, dataset, *, n_timing=30, n_ood=400, ood_seed=2719,
                         write=True):
    """Calibrate shipped model ``name`` on ``dataset`` and write its calibration file.

    Args:
        name: a shipped model (:func:`~nh_operators.available_pretrained`).
        dataset: labelled :class:`~nh_operators.data.Dataset` on :data:`TIMES`, or the
            path of its HDF5 file.
        n_timing: potentials timed (batch 1; best of 3 each, median over them).
        n_ood, ood_seed: out-of-distribution potentials (:func:`ood_factor`; a seed
            other than the contract benchmark's 0): the factor becomes the larger of
            the two quantiles, so the estimate holds on both kinds of input that
            ``auto`` hands to a network. 0 skips them.
        write: write ``weights/NAME/calibration.json`` (atomically).

    Returns:
        the calibration dict: :func:`~nh_operators.solving.calibrate`'s keys plus
        ``neural_seconds`` (one network solve on :data:`TIMES`, estimate included),
        ``classical_tols`` / ``classical_seconds`` (the classical solve of the exact
        potential on :data:`TIMES` at each tolerance), ``classical_seconds_sensors``
        (from the sensor values), ``classical_seconds_formula`` (SHO, double well and
        Morse as formulas, integrated in Python) and ``device``.
    """
    from ..data import load_dataset
    from ..evaluation import device_info
    from .catalog import WEIGHTS

    from .catalog import resolve_pretrained

    name = resolve_pretrained(name)
    if not hasattr(dataset, "V"):
        dataset = load_dataset(dataset)
    model = _model(name)
    result = calibrate(model, dataset)
    result["factor_in_distribution"] = result["factor"]
    if n_ood:
        factor, count = ood_factor(name, n_ood, ood_seed, result["quantile"])
        result.update(factor_ood=factor, n_ood=count, ood_seed=ood_seed)
        if factor > result["factor"]:
            scale = factor / result["factor"]
            result["factor"] = factor
            result["estimate_quantiles"] = [v * scale for v in result["estimate_quantiles"]]
    pots = [dataset.potential(i) for i in range(min(n_timing, len(dataset)))]
    result["neural_seconds"] = _median_seconds(
        lambda pot: neural_solve(name, pot, "exact V", TIMES), pots)
    result["classical_tols"] = CLASSICAL_TOLS
    sensors = [pot.V(SENSORS) for pot in pots]
    formulas = list(PHYSICAL_POTENTIALS.values())[:3]  # smooth: SHO, double well, Morse
    for key, items, information in (("classical_seconds", pots, "exact V"),
                                     ("classical_seconds_sensors", sensors, "sensors"),
                                     ("classical_seconds_formula", formulas, "exact V")):
        result[key] = [_median_seconds(
            lambda pot: adaptive_solve(pot, information, TIMES, tol, "rk4"), items)
            for tol in CLASSICAL_TOLS]
    result["device"] = device_info("cpu")
    if write:
        path = WEIGHTS / name / CALIBRATION
        write_atomic(path, (json.dumps(result, indent=2) + "\n").encode())
        model.calibration = result
    return result
