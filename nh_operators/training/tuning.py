"""Hyperparameter tuning with Optuna: the paper's grid stage, then its TPE stage.

* Stage ``grid``: every point of a grid over an architecture's parameters, trained
  with the search space's fixed schedule (Optuna's ``GridSampler``).
* Stage ``tpe``: the initial learning rate, the schedule's upper bound and infimum
  (and β, the KL weight, for VaRONet) by the Tree-structured Parzen Estimator, on the
  architecture you pass (typically the grid stage's best, through its JSON file).

Each trial trains ``seeds`` runs (seeds 0, 1, ...) of ``epochs`` epochs and scores the
mean of their final validation losses. After every epoch the running mean is reported
to Optuna, and a ``MedianPruner`` stops trials that are worse than the median of the
earlier ones at the same point (:class:`TrialReporter`); a run whose loss becomes
non-finite is pruned too.

The study lives in an Optuna RDB storage — SQLite by default — so several processes
or machines work on one study: start the same command on each. Workers agree on the
grid order (one shuffle seed), so they split the grid instead of repeating points; a
worker that dies stops sending heartbeats and its trial is handed to another worker.
The best configuration is rewritten atomically after each finished trial as a JSON
file that ``nh-operators train --config`` reads (see
:func:`~nh_operators.training.load_tuned_config`).
"""

import os
import socket
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from .._extras import require
from .config import TrainConfig, TrainingDiverged
from .trainer import train
from .tuning_spaces import (
    SEARCH_SPACES,
    STAGES,
    TUNED_KEYS,
    get_space,
    grid_size,
    load_tuned_config,
    stage_params,
    tuned_train_kwargs,
)
from .tuning_study import (
    DEFAULT_STORAGE,
    best_trial,
    check_settings,
    best_config,
    open_storage,
    open_study,
    study_name,
    write_best_config,
)

optuna = require("optuna")
TrialState = optuna.trial.TrialState

__all__ = ["DEFAULT_STORAGE", "SEARCH_SPACES", "STAGES", "TrialReporter", "best_config",
           "get_space", "load_tuned_config", "open_storage", "open_study", "study_name",
           "tune", "tuned_train_kwargs", "write_best_config"]


class TrialReporter:
    """Reports a trial's validation loss to Optuna after every epoch, and prunes.

    Seeds run one after another; at epoch e (1-based) of the seed with index i the
    reported step is ``i * epochs + e - 1`` and the value the mean over seeds 0..i of
    the validation loss at epoch e, so every trial is compared at the same point and the
    last step carries the trial's objective.

    Args:
        trial: an ``optuna.Trial`` (anything with ``report`` and ``should_prune``).
        epochs: epochs per run.
        n_seeds: runs per trial.

    Example:
        >>> reporter = TrialReporter(trial, epochs=10, n_seeds=2)  # doctest: +SKIP
        >>> train(config, data, out, epoch_callback=reporter.callback(0))  # doctest: +SKIP
    """

    def __init__(self, trial, epochs, n_seeds):
        self.trial, self.epochs = trial, int(epochs)
        self.losses = np.full((int(n_seeds), self.epochs), np.nan)

    def callback(self, index):
        """The ``epoch_callback`` for the run with seed index ``index``.

        Raises (from the callback):
            optuna.TrialPruned: when the trial's pruner says so.
        """
        def report(record, net):
            epoch = int(record["epoch"])
            self.losses[index, epoch - 1] = record["val_loss"]
            value = float(np.mean(self.losses[:index + 1, epoch - 1]))
            self.trial.report(value, index * self.epochs + epoch - 1)
            if self.trial.should_prune():
                raise optuna.TrialPruned(f"pruned at seed index {index}, epoch {epoch}: "
                                         f"running mean validation loss {value:.4g}")
        return report


class _Objective:
    """One trial: sample, train every seed, return the mean final validation loss."""

    def __init__(self, model, stage, space, data, base, epochs, seeds, workdir):
        self.model, self.stage, self.space, self.data = model, stage, space, data
        self.params = stage_params(space, model, stage)
        self.base, self.epochs, self.seeds = base, epochs, seeds
        self.workdir = workdir

    def __call__(self, trial):
        trial.set_user_attr("worker", f"{socket.gethostname()}:{os.getpid()}")
        if self.stage == "grid" and _extra_grid_trial(trial):
            trial.set_user_attr("skipped", "every grid point was already taken")
            trial.study.stop()
            raise optuna.TrialPruned("the grid is exhausted")
        config = self.config({k: _suggest(trial, k, v) for k, v in self.params.items()})
        resolved = TrainConfig(**config, epochs=self.epochs).resolved()
        trial.set_user_attr("config", {k: resolved[k] for k in TUNED_KEYS})
        if not resolved["infimum_lr"] < resolved["lr"]:
            trial.set_user_attr("invalid", "infimum_lr is not below lr")
            raise optuna.TrialPruned("infimum_lr is not below lr")
        reporter = TrialReporter(trial, self.epochs, len(self.seeds))
        start, finals = time.perf_counter(), []
        for index, seed in enumerate(self.seeds):
            cfg = TrainConfig(**config, epochs=self.epochs, seed=seed)
            with _run_dir(self.workdir, trial.number, seed) as out:
                try:
                    _, history = train(cfg, self.data, out, progress=False,
                                       epoch_callback=reporter.callback(index))
                except TrainingDiverged:
                    trial.set_user_attr("diverged", f"seed {seed}")
                    raise optuna.TrialPruned(f"training diverged (seed {seed})") from None
                except KeyboardInterrupt:
                    if self.stage == "grid":  # the trial fails: queue its point again
                        _queue_again(trial)
                    raise
                finally:
                    trial.set_user_attr("seconds", time.perf_counter() - start)
            finals.append(history[-1]["val_loss"])
        trial.set_user_attr("val_losses", finals)
        return float(np.mean(finals))

    def config(self, params):
        """``TrainConfig`` arguments (no epochs or seed): space < base < sampled."""
        defaults = {"preset": self.space["preset"],
                    "batch_size": self.space.get("batch_size", 100)}
        if self.stage == "grid":
            defaults.update(self.space["schedule"].get(self.model, {}))
        config = {**defaults, **self.base, "model": self.model}
        if self.stage == "grid":
            config["arch"] = {**config.get("arch", {}), **params}
        else:
            config.update(params)
        return config


def _suggest(trial, name, spec):
    if isinstance(spec, list):
        return trial.suggest_categorical(name, spec)
    return trial.suggest_float(name, spec["low"], spec["high"], log=spec.get("log", False))


def _frozen(trial):
    """The stored state of a running trial (its system attributes)."""
    return next(t for t in trial.study.get_trials(deepcopy=False,
                                                  states=(TrialState.RUNNING,))
                if t.number == trial.number)


def _extra_grid_trial(trial):
    """Whether a grid trial only exists because workers raced past the grid's end: an
    earlier trial already holds its point (retries and enqueued trials keep theirs)."""
    trials = trial.study.get_trials(deepcopy=False)
    attrs = next(t for t in trials if t.number == trial.number).system_attrs
    if "grid_id" not in attrs or {"failed_trial", "fixed_params"} & set(attrs):
        return False
    return any(t.number < trial.number and t.state != TrialState.WAITING
               and t.system_attrs.get("grid_id") == attrs["grid_id"] for t in trials)


def _grid_left(trials, n_grid):
    """Grid points no trial has started, plus the trials waiting to be retried."""
    taken = {t.system_attrs.get("grid_id") for t in trials if t.state != TrialState.WAITING}
    waiting = sum(t.state == TrialState.WAITING for t in trials)
    return n_grid - len(taken - {None}) + waiting


def _queue_again(trial):
    """A waiting copy of a grid trial, with its point (``grid_id``), for the next worker:
    the way Optuna retries a trial whose worker died."""
    frozen = _frozen(trial)
    trial.study.add_trial(optuna.trial.create_trial(
        state=TrialState.WAITING, params=frozen.params, distributions=frozen.distributions,
        system_attrs={**frozen.system_attrs, "failed_trial": frozen.number}))


class _run_dir:
    """``workdir/trial-NNNNN/seed-S`` (kept), or a temporary folder removed afterwards."""

    def __init__(self, workdir, number, seed):
        self.workdir, self.number, self.seed = workdir, number, seed
        self.tmp = None

    def __enter__(self):
        if self.workdir is None:
            self.tmp = tempfile.TemporaryDirectory(prefix="nh-tune-")
            return Path(self.tmp.name)
        return Path(self.workdir) / f"trial-{self.number:05d}" / f"seed-{self.seed}"

    def __exit__(self, *exc):
        if self.tmp is not None:
            self.tmp.cleanup()


class _Progress:
    """One line per finished trial with the best so far; rewrites the best-config file."""

    def __init__(self, out, stream, n_grid):
        self.out, self.stream, self.n_grid = out, stream, n_grid

    def __call__(self, study, trial):
        if self.n_grid is not None and _grid_left(study.get_trials(deepcopy=False),
                                                  self.n_grid) <= 0:
            study.stop()  # every grid point is taken: start no extra trial
        best = best_trial(study)
        if self.out is not None and best is not None:
            write_best_config(study, self.out)
        if self.stream is None:
            return
        params = ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                           for k, v in trial.params.items())
        if trial.state == TrialState.COMPLETE:
            what = f"{trial.value:.4g}"
        else:
            what = trial.state.name.lower()
            if trial.last_step is not None and trial.state == TrialState.PRUNED:
                what += f" at step {trial.last_step}"
            what += "".join(f", {k}" for k in ("diverged", "invalid", "skipped")
                            if k in trial.user_attrs)
        seconds = trial.user_attrs.get("seconds", 0.0)
        tail = "none completed" if best is None else f"{best.value:.4g} (trial {best.number})"
        print(f"[{study.study_name}] trial {trial.number}: {what} ({params}; {seconds:.1f} s)"
              f" | best {tail}", file=self.stream, flush=True)


def tune(model, stage, data, *, n_trials=None, timeout=None, storage=DEFAULT_STORAGE,
         space="cpu", study=None, epochs=None, seeds=None, base=None, workdir=None,
         out=None, device="auto", pruner=None, seed=None, progress=True):
    """Run (or join) a tuning study: this worker runs up to ``n_trials`` trials.

    Args:
        model: a key of :data:`nh_operators.MODELS`.
        stage: "grid" (architecture grid at a fixed schedule) or "tpe" (lr, upper
            bound, infimum, and β for VaRONet).
        data: dataset ``.h5`` path or :class:`~nh_operators.data.Dataset` (the training
            part trains, the validation part scores).
        n_trials: trials for this worker; ``None``: the rest of the grid (grid stage)
            or until ``timeout`` (TPE stage, which then needs one).
        timeout: minutes after which no new trial starts (the running one finishes).
        storage: RDB URL or Optuna storage; every worker of a study uses the same.
        space: search space: "cpu", "paper", a ``.json`` file or a dict (:func:`get_space`).
        study: study name; default :func:`study_name`.
        epochs, seeds: epochs per run and runs per trial (seeds 0..seeds-1, or a list);
            default the space's (cpu: 10 and 2; paper: 50 and 5).
        base: ``TrainConfig`` arguments the trials start from (e.g. the grid stage's
            best through :func:`load_tuned_config`, or ``{"arch": {...}}``); sampled
            values replace its own.
        workdir: keep the run directories as ``workdir/STUDY/trial-NNNNN/seed-S``;
            default temporary folders, removed after each run.
        out: JSON file for the best configuration (rewritten after every trial).
        device: training device ("auto", "cpu", "cuda", ...).
        pruner, seed: see :func:`open_study`.
        progress: print one line per finished trial with the best so far.

    Returns:
        The ``optuna.Study``; :func:`best_config` gives its best configuration.

    Raises:
        ValueError: unknown model, stage or space, a rejected storage URL, a study
            started with other settings (space, epochs, seeds, base, dataset), or no
            stopping rule for the TPE stage.

    Example:
        >>> study = tune("deeponet", "tpe", "standard.h5", n_trials=50,
        ...              out="deeponet.json")  # doctest: +SKIP
        >>> best_config(study)["lr"]  # doctest: +SKIP
    """
    resolved = get_space(space)
    stage_params(resolved, model, stage)
    if stage == "tpe" and n_trials is None and timeout is None:
        raise ValueError("the tpe stage needs n_trials or a timeout")
    epochs = resolved["epochs"] if epochs is None else int(epochs)
    seeds = resolved["seeds"] if seeds is None else seeds
    seeds = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    if not seeds:
        raise ValueError("seeds must name at least one seed")
    base = {k: v for k, v in (base or {}).items() if v is not None}
    device = base.pop("device", device)
    for key in ("model", "epochs", "seed"):
        if key in base and (key != "model" or base[key] != model):
            raise ValueError(f"base may not set {key!r} ({base[key]!r}): tune sets it")
    base.pop("model", None)
    if isinstance(data, (str, Path)):
        from ..data import load_dataset

        data = load_dataset(data)
    st = open_study(model, stage, storage=storage, space=space, study=study,
                    pruner=pruner, seed=seed)
    check_settings(st, {"model": model, "stage": stage, "space": resolved,
                         "epochs": epochs, "seeds": seeds, "base": base,
                         "data": data.checksum})
    n_grid = grid_size(resolved, model) if stage == "grid" else None
    if workdir is not None:
        workdir = Path(workdir) / st.study_name
    objective = _Objective(model, stage, resolved, data, {**base, "device": device},
                           epochs, seeds, workdir)
    trials = st.get_trials(deepcopy=False)
    stream = sys.stdout if progress else None
    runs = n_trials
    if stage == "grid":
        left = max(_grid_left(trials, n_grid), 0)
        runs = left if n_trials is None else min(n_trials, left)
        if runs == 0 and stream is not None:
            print(f"[{st.study_name}] every point of the {n_grid}-point grid is taken",
                  file=stream, flush=True)
    if stream is not None and runs != 0:
        done = sum(t.state == TrialState.COMPLETE for t in trials)
        print(f"[{st.study_name}] {len(trials)} trials so far ({done} complete)"
              + (f" of a {n_grid}-point grid" if n_grid else "")
              + ("; this worker runs trials until the timeout" if runs is None
                 else f"; this worker runs up to {runs} more")
              + f", {len(seeds)} seed(s) x {epochs} epochs each", file=stream, flush=True)
    if runs is None or runs > 0:
        st.optimize(objective, n_trials=runs,
                    timeout=None if timeout is None else 60.0 * timeout,
                    callbacks=[_Progress(out, stream, n_grid)])
    if out is not None:
        write_best_config(st, out)
    return st
