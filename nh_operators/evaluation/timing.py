"""Timing done right: warm-up, device synchronisation, medians, and where it was measured.

Every figure carries the device and thread counts it was measured with
(:func:`device_info`). Two regimes are timed the same way for every method:

* **batch 1** — one potential per call, as a user solving one scene would; the paper's
  "per-potential time". Each of ``n`` potentials is timed ``repeats`` times; a
  potential's time is its median, and the set is summarised by mean/std/median/IQR.
* **batched** — all ``N`` potentials in one call (a network in batches of its own
  ``batch_size``); seconds per trajectory = median call time / N.
"""

import os
import platform
import time

import numpy as np

from .._metrics import summarize

__all__ = ["cpu_name", "device_info", "busy_machine_warning", "time_call",
           "seconds_per_trajectory"]


def cpu_name():
    """The CPU model (from /proc/cpuinfo where there is one), else the platform's name."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def device_info(device="cpu"):
    """Describe where timings are taken.

    Args:
        device: ``"cpu"`` or a CUDA device string.

    Returns:
        dict: ``device`` (a readable name: CPU model and core count, or the GPU's
        name), ``torch_threads``, ``numba_threads``, ``cpu_count``, ``load_average``
        (1-minute, when timing started), ``platform``.

    Example:
        >>> info = device_info()
        >>> info["torch_threads"] >= 1 and "cpu" in info["device"]
        True
    """
    import numba
    import torch

    if str(device).startswith("cuda"):
        name = f"cuda: {torch.cuda.get_device_name(torch.device(device))}"
    else:
        name = f"cpu: {cpu_name()}, {os.cpu_count()} logical cores"
    return {"device": name, "torch_threads": torch.get_num_threads(),
            "numba_threads": numba.get_num_threads(), "cpu_count": os.cpu_count(),
            "load_average": _load_average(), "platform": platform.platform()}


def _load_average():
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:
        return None


def busy_machine_warning(info):
    """A sentence when other work was running (1-minute load ≥ cores), else None.

    Multi-threaded calls then wait for scheduler slices: batch-1 times of
    microsecond-scale calls grow to milliseconds. Timings taken so are not comparable.
    """
    load, cores = info.get("load_average"), info.get("cpu_count") or 1
    if load is not None and load >= cores:
        return (f"the machine was busy while timing (1-minute load average {load:g} on "
                f"{cores} cores): times are inflated and noisy; rerun on a quiet machine")
    return None


def time_call(fn, *, repeats=5, warmup=1, synchronize=None):
    """Seconds of ``repeats`` calls of ``fn()`` after ``warmup`` untimed ones.

    Args:
        fn: callable with no arguments.
        repeats: timed calls (≥ 1).
        warmup: untimed calls first (compilation, caches, CUDA context).
        synchronize: callable run before starting and before stopping each clock
            (e.g. ``torch.cuda.synchronize``), so asynchronous device work is counted.

    Returns:
        list of ``repeats`` durations in seconds (take the median).

    Raises:
        ValueError: if ``repeats`` < 1 or ``warmup`` < 0.

    Example:
        >>> len(time_call(lambda: sum(range(100)), repeats=3))
        3
    """
    if repeats < 1 or warmup < 0:
        raise ValueError(f"need repeats ≥ 1 and warmup ≥ 0, got {repeats} and {warmup}")
    sync = synchronize or (lambda: None)
    for _ in range(warmup):
        fn()
    sync()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        sync()
        times.append(time.perf_counter() - start)
    return times


def seconds_per_trajectory(method, V, t, *, n_single=20, repeats=5, batched=True):
    """Time a method at batch 1 and at full batch on the same inputs.

    Args:
        method: a :class:`~nh_operators.evaluation.Method`.
        V: sensor values (N, 100); the batched regime uses all of them, batch 1 the
            first ``n_single``.
        t: query times (M,).
        n_single: potentials timed one at a time.
        repeats: timed calls per potential (batch 1) and of the whole batch.
        batched: also time the full batch.

    Returns:
        dict: ``batch_1`` (median seconds per potential at batch 1), ``batch_1_stats``
        (mean/std/median/IQR over potentials of each one's median), ``batched``
        (median seconds of the full call / N, or None), ``batched_size`` (N), and
        ``repeats``.

    Example:
        >>> import nh_operators as nh
        >>> from nh_operators.evaluation.methods import CLASSICAL_METHODS
        >>> V = np.tile(nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS), (8, 1))
        >>> r = seconds_per_trajectory(CLASSICAL_METHODS["rk4_sensors_1"], V, nh.TIMES,
        ...                            n_single=2, repeats=2)
        >>> r["batched_size"], r["batch_1"] > 0
        (8, True)
    """
    V = np.asarray(V, dtype=np.float64)
    if V.ndim != 2 or len(V) == 0:
        raise ValueError(f"V must have shape (N, 100) with N ≥ 1, got {V.shape}")
    sync = method.synchronize
    singles = []
    for i in range(min(n_single, len(V))):
        v = V[i:i + 1]
        singles.append(float(np.median(time_call(lambda v=v: method(v, t), repeats=repeats,
                                                 warmup=1, synchronize=sync))))
    result = {"batch_1": float(np.median(singles)), "batch_1_stats": summarize(singles),
              "batched": None, "batched_size": int(len(V)), "repeats": int(repeats)}
    if batched:
        times = time_call(lambda: method(V, t), repeats=repeats, warmup=1, synchronize=sync)
        result["batched"] = float(np.median(times)) / len(V)
    return result
