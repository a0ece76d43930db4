"""The statistics of a calibration: the families, the bound on a quantile, the factors per
bin, and which calls are early.

A network's calibration (:func:`~nh_operators.solving.calibrate_pretrained`) bounds the
ratio of the true L_tot to the raw estimate over families of inputs. Two kinds of input
have different truths:

* an **exact** potential (a B-spline curve, a formula): the truth is its own trajectory,
  and the network, which sees only the 100 sensor values, errs by at least the sensors'
  information floor, which the estimate (made on the same exact force) sees only through
  the prediction;
* **sensor values**: the potential *is* the spline through them, the truth is its
  trajectory, and there is no floor to miss.

So a calibration (:class:`~nh_operators.solving.calibration.Calibration`) has one factor
table for the families of exact potentials and one for the families whose inputs were
sensor values (from every distribution tried).

Calls whose latest time is at most :data:`EARLY_HORIZON` are bounded apart
(:class:`~nh_operators.solving.kinds.CallKind`): there the estimate can miss the error
by two orders of magnitude (the first grid steps of a prediction are not averaged over
the orbit), and a factor for them would waste every other call.
"""

import numpy as np

__all__ = ["CONFIDENCE", "EARLY_HORIZON", "SENSOR_FAMILIES", "bin_factors", "upper_quantile"]

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
