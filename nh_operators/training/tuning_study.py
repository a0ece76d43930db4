"""Optuna storage and studies for :mod:`nh_operators.training.tuning`, and the best
configuration of a study as a tuned-config file.

Every worker of a study opens it with the same name and storage; the study records the
settings its first worker used (search space, epochs, seeds, starting config, dataset
checksum) and refuses workers that bring others.
"""

import json
import time
import warnings
from pathlib import Path
from typing import Any

from .._extras import require
from .._version import __version__
from ..models import training_defaults
from .checkpoint import write_atomic
from .tuning_spaces import SEARCH_SPACES, get_space, stage_params

optuna = require("optuna")
TrialState = optuna.trial.TrialState

__all__ = ["DEFAULT_STORAGE", "best_config", "open_storage", "open_study", "study_name",
           "write_best_config"]

#: Optuna storage used when none is given: a SQLite file in the working folder.
DEFAULT_STORAGE = "sqlite:///tune.db"
_SETTINGS = "nh_operators"  # study user attribute holding what every worker must share
_HEARTBEAT = 30  # seconds; a trial silent for 4 heartbeats is failed and retried once
_SCHEMA_RETRIES = 5


def _masked(url):
    import sqlalchemy.exc
    from sqlalchemy.engine import make_url

    try:
        return make_url(url).render_as_string(hide_password=True)
    except (ValueError, sqlalchemy.exc.ArgumentError):
        return url  # not a URL: nothing to hide


def open_storage(url=DEFAULT_STORAGE):
    """An Optuna RDB storage with heartbeats, shared safely by several workers.

    SQLite connections wait up to 60 s for a lock; workers that create the database
    tables at the same moment retry instead of failing; a trial whose worker stopped
    sending heartbeats (killed, machine lost) is marked failed and queued once more with
    the same parameters.

    Args:
        url: an SQLAlchemy URL Optuna accepts (``sqlite:///tune.db``,
            ``postgresql://user:pass@host/db``, ``mysql+pymysql://...``).

    Returns:
        An ``optuna.storages.RDBStorage``.

    Raises:
        ValueError: if Optuna rejects the URL (malformed, driver missing, unreachable).

    Example:
        >>> storage = open_storage("sqlite:///:memory:")
    """
    import sqlalchemy.exc

    storages = optuna.storages
    kwargs: dict[str, Any] = {"heartbeat_interval": _HEARTBEAT,
                              "grace_period": 4 * _HEARTBEAT}
    if str(url).startswith("sqlite"):
        kwargs["engine_kwargs"] = {"connect_args": {"timeout": 60}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        warnings.simplefilter("ignore", FutureWarning)
        if hasattr(storages, "RetryHeartbeatStaleTrialCallback"):  # optuna >= 4.9
            kwargs["heartbeat_stale_trial_callback"] = \
                storages.RetryHeartbeatStaleTrialCallback(max_retry=1)
        else:
            kwargs["failed_trial_callback"] = storages.RetryFailedTrialCallback(max_retry=1)
        for attempt in range(_SCHEMA_RETRIES + 1):
            try:
                return storages.RDBStorage(str(url), **kwargs)
            except (ImportError, ValueError, TypeError, sqlalchemy.exc.SQLAlchemyError) as err:
                if attempt < _SCHEMA_RETRIES and _schema_race(err):
                    time.sleep(0.25 * (attempt + 1))  # the other worker finishes the schema
                    continue
                raise ValueError(f"optuna rejected the storage URL {_masked(str(url))!r}: "
                                 f"{type(err).__name__}: {err}") from err


def _schema_race(err):
    """Whether an error is another worker creating the same tables at the same moment
    (Optuna creates its schema on first use, without a lock)."""
    text = str(err).lower()
    return any(s in text for s in ("already exists", "unique constraint", "duplicate"))


def study_name(model, stage, space="cpu"):
    """The default study name: ``MODEL-STAGE-SPACE`` (e.g. ``deeponet-tpe-cpu``); a space
    given as a file contributes its stem, a dict ``custom``."""
    if isinstance(space, dict):
        label = "custom"
    else:
        label = str(space) if str(space) in SEARCH_SPACES else Path(space).stem
    return f"{model}-{stage}-{label}"


def open_study(model, stage, *, storage=DEFAULT_STORAGE, space="cpu", study=None,
               pruner=None, seed=None):
    """Create or load (``load_if_exists``) the study of one model and stage.

    Args:
        model: a key of :data:`nh_operators.MODELS`.
        stage: "grid" or "tpe".
        storage: an RDB URL (see :func:`open_storage`) or an Optuna storage object.
        space: a search-space name, ``.json`` file or dict (:func:`get_space`).
        study: the study's name; default :func:`study_name`.
        pruner: an Optuna pruner; default a ``MedianPruner`` with the space's settings.
        seed: seed of the TPE sampler (default: fresh entropy, so that parallel workers
            draw different points). The grid order always uses seed 0, shared by all
            workers.

    Returns:
        An ``optuna.Study`` minimising the mean validation loss.

    Raises:
        ValueError: unknown model, stage or space, or a storage URL Optuna rejects.

    Example:
        >>> s = open_study("deeponet", "grid", storage="sqlite:///:memory:")
        >>> s.study_name
        'deeponet-grid-cpu'
    """
    resolved = get_space(space)
    params = stage_params(resolved, model, stage)
    if isinstance(storage, str):
        storage = open_storage(storage)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        if stage == "grid":
            sampler = optuna.samplers.GridSampler(params, seed=0)
        else:
            sampler = optuna.samplers.TPESampler(seed=seed, constant_liar=True)
    if pruner is None:
        pruner = optuna.pruners.MedianPruner(**resolved.get("pruner", {}))
    return optuna.create_study(storage=storage, sampler=sampler, pruner=pruner,
                               study_name=study or study_name(model, stage, space),
                               direction="minimize", load_if_exists=True)


def best_trial(study):
    """The completed trial of ``study`` with the lowest value, or None while none has
    completed.

    Example:
        >>> best_trial(study).number  # doctest: +SKIP
        7
    """
    done = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    return min(done, key=lambda t: t.value) if done else None


def best_config(study):
    """The best trial as a tuned-config dict (the JSON ``train --config`` reads).

    Returns:
        ``{"model", "preset", "arch", "lr", "upper_bound", "infimum_lr"[, "beta"],
        "tuning": {...}}`` with ``arch`` complete, or ``None`` while no trial has
        completed. ``tuning`` records the study, stage, trial, value, per-seed losses,
        epochs, seeds and trial counts (not loaded by ``train``).

    Example:
        >>> study = optuna.load_study(study_name="deeponet-tpe-cpu",
        ...                           storage="sqlite:///tune.db")  # doctest: +SKIP
        >>> best_config(study)["lr"]  # doctest: +SKIP
        0.005933
    """
    best = best_trial(study)
    if best is None:
        return None
    settings = study.user_attrs.get(_SETTINGS, {})
    config = dict(best.user_attrs["config"])
    if "beta" not in training_defaults(config["model"]):
        config.pop("beta", None)
    states = [t.state.name.lower() for t in study.get_trials(deepcopy=False)]
    config["tuning"] = {
        "study": study.study_name, "stage": settings.get("stage"), "trial": best.number,
        "value": best.value, "val_losses": best.user_attrs.get("val_losses"),
        "params": best.params, "epochs": settings.get("epochs"),
        "seeds": settings.get("seeds"), "data": settings.get("data"),
        "trials": {s: states.count(s) for s in sorted(set(states))},
        "version": __version__,
    }
    return config


def write_best_config(study, path):
    """Atomically write :func:`best_config` as JSON (a temporary file, then a rename).

    Args:
        study: an ``optuna.Study`` made by :func:`nh_operators.training.tune`.
        path: the JSON file (its folder must exist).

    Returns:
        The dict written, or ``None`` (nothing written) while no trial has completed.

    Example:
        >>> write_best_config(study, "best.json")  # doctest: +SKIP
    """
    config = best_config(study)
    if config is not None:
        write_atomic(path, (json.dumps(config, indent=2) + "\n").encode())
    return config


def check_settings(study, settings):
    """Record ``settings`` (JSON-able) on a new ``study``, or check they match its own.

    Raises:
        ValueError: the study was started with other settings (the differing keys named).

    Example:
        >>> check_settings(study, {"model": "deeponet", "stage": "tpe"})  # doctest: +SKIP
    """
    mine = json.loads(json.dumps(settings))
    theirs = study.user_attrs.get(_SETTINGS)
    if theirs is None:
        study.set_user_attr(_SETTINGS, mine)
    elif theirs != mine:
        diff = sorted(k for k in set(mine) | set(theirs) if mine.get(k) != theirs.get(k))
        raise ValueError(f"study {study.study_name!r} was started with other settings "
                         f"(they differ in {diff}); use the same ones or another --study")
