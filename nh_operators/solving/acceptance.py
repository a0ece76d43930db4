"""Reading a calibration: the calibrated estimate and the share it accepts, by input kind.

A network's calibration (:func:`~nh_operators.solving.calibrate_pretrained`) bounds the
ratio of the true L_tot to the raw estimate over families of inputs. Two kinds of input
have different truths:

* an **exact** potential (a B-spline curve, a formula): the truth is its own trajectory,
  and the network, which sees only the 100 sensor values, errs by at least the sensors'
  information floor, which the estimate (made on the same exact force) sees only through
  the prediction;
* **sensor values**: the potential *is* the spline through them, the truth is its
  trajectory, and there is no floor to miss.

So a calibration has ``factors`` (the families of exact potentials) and, where
calibrated, ``factors_sensors`` (the families whose inputs were sensor values, from
every distribution tried). A calibration without them (an older file) gives sensor
values the ``factors`` of every family, as before.

Calls whose latest time is at most :data:`EARLY_HORIZON` are bounded apart, by
``factors_early`` and ``factors_sensors_early``: there the estimate can miss the error
by two orders of magnitude (the first grid steps of a prediction are not averaged over
the orbit), and a factor for them would waste every other call.
"""

import numpy as np

__all__ = ["SENSOR_FAMILIES", "EARLY_HORIZON", "upper_quantile", "bin_factors", "calibrated",
           "acceptance_rate", "cautious_acceptance_rate"]

#: A call whose latest asked time is at most this (a quarter of the grid) is an early
#: call. On phaseonet-paper, true / raw reached 280 for calls up to t = 0.1, 7 up to 0.5,
#: 3–5 beyond (``benchmarks/promise/estimate_horizons.py``).
EARLY_HORIZON = 0.5

#: The confidence of the bound on a quantile (:func:`upper_quantile`).
CONFIDENCE = 0.95

#: The calibration families whose inputs are sensor values (their truth: the spline's
#: trajectory), by the exact family they mirror.
SENSOR_FAMILIES = {"in distribution": "sensors",
                   "other distribution": "sensors: other distribution",
                   "out of distribution": "sensors: out of distribution"}


def _sensor_calibrated(calibration):
    return bool(calibration) and "factors_sensors" in calibration


def calibrated(raw, calibration, kind="exact", early=False, fine=False):
    """The calibrated estimate of raw estimates ``raw`` under a model's ``calibration``,
    for an input of ``kind`` (``"exact"`` or ``"sensors"``) and calls that are ``early``
    or not (a bool, or one per raw estimate); ``fine``: raw estimates on the finer grid
    of :mod:`~nh_operators.solving.refine` (calls of the whole orbit only; infinite
    where the calibration has no factors for them).

    ``factors[k] · raw`` for raw in bin k, the bins split at ``limits`` (the raw estimate
    is first order in the error: as the error grows, its ratio to the truth spreads
    more); sensor values use ``factors_sensors``, early calls the ``_early`` factors,
    where calibrated. A calibration with one ``factor`` applies it everywhere; ``None``
    leaves ``raw`` as it is.

    Example:
        >>> cal = {"factor": 2.0, "factors": [2.0, 3.0, 8.0], "limits": [1e-3, 1e-2]}
        >>> calibrated(np.array([1e-4, 1e-3, 5e-3, 0.1]), cal).tolist()
        [0.0002, 0.002, 0.015, 0.8]
        >>> cal["factors_sensors"] = [0.5, 1.0, 4.0]
        >>> calibrated(np.array([1e-4, 0.1]), cal, "sensors").tolist()
        [5e-05, 0.4]
        >>> cal["factors_sensors_early"] = [50.0, 50.0, 50.0]
        >>> calibrated(np.array([1e-4, 1e-4]), cal, "sensors", [True, False]).tolist()
        [0.005, 5e-05]
    """
    if kind not in ("exact", "sensors"):
        raise ValueError(f"kind must be 'exact' or 'sensors', got {kind!r}")
    raw = np.asarray(raw, dtype=np.float64)
    if not calibration:
        return raw
    key = "factors_sensors" if kind == "sensors" and _sensor_calibrated(calibration) \
        else "factors"
    limits = calibration.get("limits", [])
    bins = np.searchsorted(limits, raw, side="left")
    if fine:
        factors = calibration.get(key + "_fine")
        return np.full(raw.shape, np.inf) if factors is None else np.asarray(factors)[bins] * raw
    out = np.asarray(calibration.get(key, [calibration["factor"]]))[bins] * raw
    if np.any(early) and key + "_early" in calibration:
        out = np.where(early, np.asarray(calibration[key + "_early"])[bins] * raw, out)
    return out


def acceptance_rate(calibration, tol, family=None, kind="exact"):
    """Fraction of the calibration set (its in-distribution family, or ``family``)
    whose calibrated estimate is ≤ tol (interpolated between the stored quantiles in log
    scale). ``kind="sensors"`` reads the sensor-value family that mirrors ``family``
    (:data:`SENSOR_FAMILIES`) where the calibration has sensor factors."""
    if kind == "sensors" and _sensor_calibrated(calibration):
        family = SENSOR_FAMILIES[family or "in distribution"]
    quantiles = (calibration["estimate_quantiles"] if family is None else
                 calibration["families"][family]["estimate_quantiles"])
    est = np.log(np.maximum(quantiles, 1e-300))
    return float(np.interp(np.log(tol), est, calibration["probabilities"], left=0.0,
                           right=1.0))


def cautious_acceptance_rate(calibration, tol, kind="exact"):
    """The smaller of :func:`acceptance_rate` on the network's own distribution and on
    the other generator's potentials its domain admits (where calibrated): what a single
    call, which cannot tell which generator its input came from, may count on."""
    shares = [acceptance_rate(calibration, tol, kind=kind)]
    families = calibration.get("families", {})
    other = "other distribution"
    if kind == "sensors" and _sensor_calibrated(calibration):
        other = SENSOR_FAMILIES[other]
    if "estimate_quantiles" in families.get(other, {}):
        shares.append(acceptance_rate(calibration, tol, other))
    return min(shares)


def bin_factors(entries, key="bins"):
    """Each bin's factor over the family ``entries`` (their bins under ``key``): the
    largest family bound in it (a bin no sample reached takes the largest of all), never
    below a lower bin's, as the estimate grows with raw; None where no family has a
    sample."""
    entries = list(entries)
    if not entries:
        return None
    bounds = [[f[key][k]["bound"] for f in entries if f[key][k]["n"]]
              for k in range(len(entries[0][key]))]
    if not any(bounds):
        return None
    top = max(b for bs in bounds for b in bs)
    return np.maximum.accumulate([max(bs) if bs else top for bs in bounds]).tolist()


def upper_quantile(ratios, quantile, confidence=CONFIDENCE, resamples=2000, seed=0):
    """A bootstrap upper confidence bound on the ``quantile`` of ``ratios``: the
    ``confidence`` quantile of the sample quantile over ``resamples`` resamples.

    Example:
        >>> r = np.random.default_rng(1).lognormal(size=3000)
        >>> bool(np.quantile(r, 0.999) <= upper_quantile(r, 0.999) <= r.max())
        True
    """
    ratios = np.asarray(ratios, dtype=np.float64)
    rng = np.random.default_rng(seed)
    picks = rng.integers(0, ratios.size, size=(resamples, ratios.size))
    boot = np.quantile(ratios[picks], quantile, axis=1, method="higher")
    return float(np.quantile(boot, confidence))
