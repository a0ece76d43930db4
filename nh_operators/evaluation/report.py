"""Evaluate methods side by side: test-set losses, physical potentials, timings.

:func:`evaluate_methods` is what ``nh-operators evaluate`` and ``benchmark`` run. Its
result has the shape of ``report.json``::

    {"methods": {NAME: {"test": {"mean", "std", "median", "iqr", "n"},
                        "physical": {"sho", "double_well", "morse", "mff", "smff"},
                        "seconds_per_trajectory": {"batch_1", "batched", ...},
                        "device", "kind", "family", ...}}}

Per-method results are cached in ``cache_dir`` (atomically, keyed by the test set's
checksum, the method and the settings), so an interrupted evaluation resumes where it
stopped and a repeated one reuses finished methods.
"""

import hashlib
import io
import json
import logging
import time
import warnings
from pathlib import Path

import numpy as np

from .._constants import SENSORS
from .._metrics import loss_per_sample, summarize
from ..potentials import PHYSICAL_POTENTIALS
from ..training import write_atomic
from .baselines import physical_reference
from .timing import busy_machine_warning, device_info, seconds_per_trajectory

__all__ = ["EvaluationSettings", "evaluate_methods", "evaluate_method"]

log = logging.getLogger(__name__)
_NO_STATS = {"mean": float("nan"), "std": float("nan"), "median": float("nan"),
             "iqr": float("nan")}


class EvaluationSettings:
    """How much to evaluate and time (final).

    Args:
        n_unbatched: test potentials for methods that solve one trajectory at a time in
            Python (DOP853): a subset, reported as ``test.n``. Default 200.
        n_single: potentials timed one at a time (batch 1). Default 20.
        n_batched: potentials in the batched timing call (the first ones of the test
            set). Unbatched methods loop in Python: their batched time is that of the
            scoring call on ``n_unbatched`` potentials. Default 1000.
        repeats: timed calls per measurement; the median is kept. Default 5.
        timing: measure times at all. Default True.
    """

    def __init__(self, *, n_unbatched=200, n_single=20, n_batched=1000, repeats=5,
                 timing=True):
        for key, value in (("n_unbatched", n_unbatched), ("n_single", n_single),
                           ("n_batched", n_batched), ("repeats", repeats)):
            if int(value) != value or value < 1:
                raise ValueError(f"{key} must be a positive integer, got {value}")
        self.n_unbatched, self.n_single = int(n_unbatched), int(n_single)
        self.n_batched, self.repeats, self.timing = int(n_batched), int(repeats), bool(timing)

    def as_dict(self):
        return dict(vars(self))


def _fingerprint(method):
    run_dir = getattr(method, "run_dir", None)
    if run_dir is None:
        return method.name
    path = Path(run_dir)
    path = path / "checkpoint.pt" if path.is_dir() else path
    return method.name + ":" + hashlib.sha256(path.read_bytes()).hexdigest()


def evaluate_method(method, dataset, settings=None):
    """Score and time one method on a dataset and on the five physical potentials.

    Args:
        method: a :class:`~nh_operators.evaluation.Method`.
        dataset: a :class:`~nh_operators.data.Dataset` with labels (the test set).
        settings: :class:`EvaluationSettings` (default: its defaults).

    Returns:
        (entry, arrays): ``entry`` is the method's ``report.json`` record; ``arrays``
        holds ``L_tot`` (per test sample), ``worst`` (index), ``q_worst``/``p_worst``
        (its prediction) and ``physical_q``/``physical_p`` (5, M) for the figures.
    """
    settings = settings or EvaluationSettings()
    n = len(dataset) if method.batched else min(settings.n_unbatched, len(dataset))
    V, t = dataset.V[:n], dataset.t
    caught = []
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        start = time.perf_counter()
        q, p = method(V, t)
        seconds = time.perf_counter() - start
        losses = loss_per_sample(q, p, dataset.q[:n], dataset.p[:n])["L_tot"]
        physical, pq, pp = {}, [], []
        for name, pot in PHYSICAL_POTENTIALS.items():
            qr, pr = physical_reference(name, t)
            qm, pm = method(pot.V(SENSORS)[None], t)
            physical[name] = float(loss_per_sample(qm[0], pm[0], qr, pr)["L_tot"])
            pq.append(qm[0])
            pp.append(pm[0])
        caught += [f"{w.category.__name__}: {w.message}" for w in record]
    timing = None
    if settings.timing:
        n_time = min(settings.n_batched, n)
        with warnings.catch_warnings():  # already recorded above, once
            warnings.simplefilter("ignore")
            timing = seconds_per_trajectory(method, V[:n_time], t, n_single=settings.n_single,
                                            repeats=settings.repeats, batched=method.batched)
        if not method.batched:  # a Python loop: its batch is the evaluation call itself
            timing.update(batched=seconds / n, batched_size=int(n), batched_repeats=1)
    info = device_info(method.device)
    busy = busy_machine_warning(info) if settings.timing else None
    if busy:
        caught.append(f"timing: {busy}")
    worst = int(np.argmax(losses)) if np.all(np.isfinite(losses)) else int(
        np.flatnonzero(~np.isfinite(losses))[0])
    finite = np.isfinite(losses)
    entry = {
        "kind": method.kind,
        "family": method.family,
        "description": getattr(method, "description", ""),
        "test": {**(summarize(losses[finite]) if finite.any() else _NO_STATS), "n": int(n),
                 "n_nonfinite": int(n - finite.sum())},
        "physical": physical,
        "seconds_per_trajectory": timing or {"batch_1": None, "batched": None},
        "device": info["device"],
        "threads": {"torch": info["torch_threads"], "numba": info["numba_threads"]},
        "load_average": info["load_average"],
        "evaluation_seconds": seconds,
        "warnings": sorted(set(caught)),
    }
    for key in ("run_dir", "config"):
        if hasattr(method, key):
            entry[key] = getattr(method, key)
    arrays = {"L_tot": losses, "worst": np.array(worst), "q_worst": q[worst],
              "p_worst": p[worst], "physical_q": np.array(pq), "physical_p": np.array(pp)}
    return entry, arrays


def _cache_key(method, dataset, settings):
    from .._version import __version__

    key = {"method": _fingerprint(method), "dataset": dataset.checksum,
           "settings": settings.as_dict(), "version": __version__}
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()


def _load_cached(cache_dir, name, key):
    meta, npz = cache_dir / f"{name}.json", cache_dir / f"{name}.npz"
    if not (meta.exists() and npz.exists()):
        return None
    stored = json.loads(meta.read_text())
    if stored.get("key") != key:
        return None
    with np.load(npz) as f:
        return stored["entry"], {k: f[k] for k in f.files}


def _store(cache_dir, name, key, entry, arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    write_atomic(cache_dir / f"{name}.npz", buf.getvalue())
    write_atomic(cache_dir / f"{name}.json",
                 json.dumps({"key": key, "entry": entry}, default=str).encode())


def evaluate_methods(methods, dataset, settings=None, *, cache_dir=None, fresh=False,
                     progress=True):
    """Evaluate many methods (networks and classical baselines) on the same inputs.

    Args:
        methods: dict name -> :class:`~nh_operators.evaluation.Method` (the dict key is
            the report's name).
        dataset: the labelled test set.
        settings: :class:`EvaluationSettings`.
        cache_dir: folder for per-method results; finished methods are reused when
            the test set, the method (its checkpoint's hash), the settings and the
            package version match.
        fresh: ignore (and overwrite) cached results.
        progress: log a line per method (``logging`` at INFO, and a tqdm bar).

    Returns:
        (results, arrays): ``results`` shaped like ``report.json``
        (``{"methods": {...}, "test_set": {...}, "settings": {...}}``), ``arrays``
        name -> the per-method arrays of :func:`evaluate_method`.

    Raises:
        ValueError: if ``methods`` is empty.
    """
    if not methods:
        raise ValueError("nothing to evaluate: give at least one method")
    settings = settings or EvaluationSettings()
    cache = Path(cache_dir) if cache_dir is not None else None
    if cache is not None:
        cache.mkdir(parents=True, exist_ok=True)
    results = {"methods": {}, "settings": settings.as_dict(),
               "test_set": {"checksum": dataset.checksum, "n": len(dataset),
                            "seed": dataset.attrs.get("seed"),
                            "path": dataset.attrs.get("path")}}
    arrays = {}
    bar = _bar(len(methods), progress)
    for name, method in methods.items():
        bar.set_description(f"evaluating {name}")
        key = _cache_key(method, dataset, settings) if cache is not None else None
        found = _load_cached(cache, name, key) if cache is not None and not fresh else None
        if found is None:
            found = evaluate_method(method, dataset, settings)
            if cache is not None:
                _store(cache, name, key, *found)
        else:
            log.info("%s: reusing the cached result in %s", name, cache)
        results["methods"][name], arrays[name] = found
        bar.update()
    bar.close()
    return results, arrays


def _bar(total, enabled):
    from tqdm.auto import tqdm

    return tqdm(total=total, disable=not enabled, unit="method", leave=False)
