"""Training a network in DeepXDE's loop: AdamW, hyperbolic schedules, checkpoints, resume.

:func:`train` builds the network, wraps the dataset in an
:class:`~nh_operators.OperatorData`, compiles a ``dde.Model`` with an AdamW instance
(betas (0.85, 0.98)) and attaches the learning-rate schedule, which DeepXDE steps once
per *iteration*: the schedules take ``steps_per_epoch`` so that they follow the
per-epoch curve at fractional epochs. A DeepXDE callback ends every epoch with a
batched validation pass, a progress-bar update, a history row and an atomic checkpoint.
"""

import logging
import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import torch

from .._backend import ensure_pytorch_backend
from ..data import PhysicsTerms, ShardedOperatorData, check_global_batch, open_rows
from ..models import count_parameters
from .averaging import WeightAverage
from .checkpoint import CHECKPOINT, load_checkpoint, network_from_config, write_config
from .config import SCHEDULERS, TrainConfig, TrainingDiverged
from .distributed import init_distributed
from .epochs import EpochEnd, TrainingRun
from .losses import LOSSES

if TYPE_CHECKING:  # only for the annotation: imported, it would load the generator
    from ..data import Dataset

dde: Any = ensure_pytorch_backend()  # deepxde ships no type information
log = logging.getLogger(__name__)

__all__ = ["train"]


def train(config: TrainConfig, data: "str | os.PathLike[str] | Dataset",
          out: str | os.PathLike[str], *, resume: bool = False, progress: bool = True,
          epoch_callback: Callable[[dict[str, Any], torch.nn.Module], object] | None = None,
          max_minutes: float | None = None, stop_after: int | None = None,
          max_rows: int | None = None):
    """Train a network through ``dde.Model`` and write a run directory.

    Under ``torchrun`` (see :doc:`/training_at_scale`) every process calls this with the
    same arguments: each trains on its slice of every global batch of
    ``config.batch_size`` rows, the gradients are averaged by DistributedDataParallel,
    and rank 0 alone writes the run directory and draws the progress bar.

    Args:
        config: a :class:`TrainConfig`.
        data: the path of a dataset's HDF5 file (each process reads only the rows it
            trains on), or a :class:`~nh_operators.data.Dataset` in memory.
        out: run directory (created); holds ``checkpoint.pt``, ``config.json`` and
            ``history.csv`` (see :mod:`nh_operators.training.checkpoint`).
        resume: continue from ``out/checkpoint.pt`` when it exists. The config and the
            dataset checksum must match the checkpoint's; the run then ends exactly
            where an uninterrupted one would (on the same device).
        progress: show a progress bar (epoch, train and validation loss, lr, time).
        epoch_callback: called as ``epoch_callback(record, net)`` after each epoch's
            checkpoint, with the epoch's history record (a dict) and the network; on
            every rank of a distributed run (the same record everywhere).
        max_minutes: wall-time budget in minutes, counted over the whole run (resumed
            parts included). Training stops after the first epoch that ends past it,
            with that epoch's checkpoint saved; ``--resume`` with a larger budget
            continues the same schedule. Not part of the config. ``None``: no limit.
        stop_after: stop after this epoch, with the schedule of ``config.epochs`` (how a
            run cut by ``max_minutes`` is reproduced on another machine).
        max_rows: most training rows a process holds at once (default: its rows of a
            whole epoch, 1/N of the training set); a smaller value reads each epoch in
            several passes over the file, for data larger than memory.

    Returns:
        (network, history): the trained network (train mode; the weight average
        when ``config.ema``) and a list of per-epoch
        dicts with epoch, train_loss, val_loss, lr and seconds.

    Raises:
        FileExistsError: ``out`` already holds a checkpoint and ``resume`` is false.
        ValueError: bad config, a global batch the number of processes does not
            divide, or a checkpoint that does not match the config.
        TrainingDiverged: the loss became non-finite (the last good epoch's
            checkpoint stays in ``out``).
        RankFailed: another process of a distributed run died (the last checkpoint
            stays in ``out``; ``resume`` continues).

    Example:
        >>> import nh_operators as nh
        >>> cfg = nh.TrainConfig("traonet", preset="cpu", epochs=5, seed=1)
        >>> net, history = nh.train(cfg, "standard.h5", "runs/traonet")  # doctest: +SKIP
    """
    cfg = config.resolved()
    if max_minutes is not None and not max_minutes > 0:
        raise ValueError(f"max_minutes must be positive, got {max_minutes}")
    if stop_after is not None and not (int(stop_after) == stop_after and
                                       1 <= stop_after <= cfg["epochs"]):
        raise ValueError(f"stop_after must be an epoch in [1, {cfg['epochs']}], got "
                         f"{stop_after}")
    dist = init_distributed(cfg["device"])
    try:
        return _train(cfg, dist, data, Path(out), resume, progress, epoch_callback,
                      max_minutes, stop_after, max_rows)
    finally:
        dist.close()


def _train(cfg, dist, data, out, resume, progress, epoch_callback, max_minutes,
           stop_after, max_rows):
    device = dist.device
    if cfg["amp"] and device.type != "cuda":
        raise ValueError("amp (float16 autocast) is only supported on CUDA")
    check_global_batch(cfg["batch_size"], dist.world_size)
    rows = open_rows(data, verify=dist.is_main)
    reads_state = bool(cfg["arch"].get("initial_state", False))
    if rows.states != reads_state:
        raise ValueError(
            "the dataset's rows start from their own states (q0, p0), but the network "
            "does not read them: add --arch initial_state=True (TrainConfig arch "
            "{'initial_state': True})" if rows.states else
            "the network reads a starting state (initial_state=True), but the dataset "
            "has none: generate one with --states energy (or a -states- preset)")
    checksum = rows.checksum
    cfg = {**cfg, "world_size": dist.world_size}
    state = _prepare(out, resume, cfg, checksum, dist)

    with torch.random.fork_rng(devices=[device] if device.type == "cuda" else []):
        torch.manual_seed(cfg["seed"])
        net = network_from_config(cfg).to(device)
        data_obj = ShardedOperatorData(
            rows, cfg["train_fraction"], batch_size=cfg["batch_size"], rank=dist.rank,
            world_size=dist.world_size,
            dtype=np.float64 if cfg["dtype"] == "float64" else np.float32,
            beta=cfg["beta"], shuffle_seed=cfg["seed"], monitor_size=cfg["batch_size"],
            max_rows=max_rows,
            physics=None if cfg["physics"] is None else PhysicsTerms(**cfg["physics"]))
        if dist.active and hasattr(net, "noise"):
            net.noise = data_obj.batch_noise  # the global batch's noise, sliced
        model = dde.Model(data_obj, dist.wrap(net))
        opt = torch.optim.AdamW(net.parameters(), lr=cfg["lr"], betas=tuple(cfg["betas"]),
                                weight_decay=cfg["weight_decay"])
        steps = data_obj.steps_per_epoch(cfg["batch_size"])
        _untimed(dde.Model.compile)(model, opt, loss=LOSSES[cfg["loss"]], verbose=0)
        sched_cls = SCHEDULERS[cfg["scheduler"]]
        scheduler = None if sched_cls is None else sched_cls(
            opt, cfg["upper_bound"], cfg["epochs"], cfg["infimum_lr"],
            steps_per_epoch=steps, per_epoch=cfg["scheduler_step"] == "epoch")
        model.lr_scheduler = scheduler
        run = TrainingRun(cfg, out, net, data_obj, model, scheduler, dist, checksum,
                   progress, epoch_callback)
        run.max_seconds = None if max_minutes is None else 60.0 * max_minutes
        run.average = WeightAverage(net, cfg["ema"]) if cfg["ema"] else None
        if state is not None:
            _restore(run, state)
        last = cfg["epochs"] if stop_after is None else int(stop_after)
        remaining = max(0, last * steps - data_obj.cursor)
        if run.over_budget():
            if dist.is_main:
                log.warning("the run has used %.1f of its %.1f minutes; nothing to do",
                            run.history[-1]["seconds"] / 60, max_minutes)
            remaining = 0
        if dist.is_main:
            log.info("training %s (%d parameters) on %s for %d iterations, %d "
                     "process(es)", cfg["model"], count_parameters(net), device,
                     remaining, dist.world_size)
        try:
            if remaining > 0:
                with dist.terminate_as_error():
                    _fit(model, run, remaining)
        except Exception as exc:
            if dist.is_peer_failure(exc):
                raise dist.failure(exc, run.epoch + 1, run.last_saved) from exc
            if dist.active:
                log.error("rank %d of %d failed in epoch %d: %s: %s", dist.rank,
                          dist.world_size, run.epoch + 1, type(exc).__name__, exc)
            raise
        finally:
            if run.bar is not None:
                run.bar.close()
            if hasattr(net, "noise"):
                cast(Any, net).noise = None  # VaRONet draws its own noise again
    if run.average is not None:  # the averaged weights are the result
        net.load_state_dict(run.average.shadow)
    if run.diverged is not None:
        epoch = (run.diverged - 1) // steps + 1
        kept = (f"the checkpoint of epoch {run.history[-1]['epoch']} is kept in "
                f"{str(out)!r}" if run.history else "no epoch finished, so there is no "
                "checkpoint")
        raise TrainingDiverged(
            f"non-finite loss in epoch {epoch} (iteration {run.diverged}); training "
            f"stopped, {kept}. Check the data for non-finite values, or try a smaller "
            f"lr (now {cfg['lr']:g}).")
    return net, run.history


def _untimed(method):
    """DeepXDE's method without its ``utils.timing`` wrapper, which prints "'train'
    took ... s" to stdout whatever the verbosity."""
    return getattr(method, "__wrapped__", method)


def _fit(model, run, iterations):
    mixed = dde.config.mixed
    dde.config.mixed = bool(run.cfg["amp"])
    try:
        with torch.device(run.device):
            _untimed(dde.Model.train)(model, iterations=iterations,
                                      batch_size=run.cfg["batch_size"],
                                      display_every=run.steps,
                                      callbacks=[EpochEnd(run)], verbose=0)
    finally:
        dde.config.mixed = mixed


def _prepare(out, resume, cfg, checksum, dist):
    """Rank 0 checks the run directory, reads the checkpoint and writes config.json;
    every rank gets the checkpoint (or the same error)."""
    outcome = None
    if dist.is_main:
        try:
            out.mkdir(parents=True, exist_ok=True)
            state = None
            if (out / CHECKPOINT).exists():
                if not resume:
                    raise FileExistsError(f"{str(out)!r} already holds a checkpoint; pass "
                                          "resume=True (--resume) or choose another "
                                          "folder")
                state = load_checkpoint(out, map_location="cpu")
                _check_resumable(state, cfg, checksum)
            write_config(out, cfg)
            outcome = (None, state)
        except (OSError, ValueError) as exc:
            if not dist.active:
                raise
            outcome = (exc, None)
    error, state = dist.broadcast(outcome)
    if error is not None:
        raise error
    return state


#: Config keys added after the first checkpoints were written, with their defaults.
_ADDED = {"loss": "mse", "ema": 0.0, "variant": "ours", "recipe": "ours",
          "scheduler_step": "iteration", "physics": None}


def _check_resumable(state, cfg, checksum):
    # the number of processes may change between parts of a run (same global batch);
    # checkpoints from before an option existed had its default
    old = {**_ADDED, **state["config"]}
    old = {k: v for k, v in old.items() if k != "world_size"}
    cfg = {k: v for k, v in cfg.items() if k != "world_size"}
    if old != cfg:
        diff = sorted(k for k in set(old) | set(cfg) if old.get(k) != cfg.get(k))
        raise ValueError(f"cannot resume: the checkpoint's config differs in {diff}")
    if state.get("data_checksum") != checksum:
        raise ValueError("cannot resume: the dataset differs from the checkpoint's "
                         "(checksum mismatch)")


def _restore(run, state):
    run.net.load_state_dict(state.get("train_model", state["model"]))
    if run.average is not None:
        run.average.load_state_dict(state["average"])
    run.model.opt.load_state_dict(state["optimizer"])
    if run.scheduler is not None:
        run.scheduler.load_state_dict(state["scheduler"])
    run.data.cursor = state["epoch"] * run.steps
    run.history = list(state["history"])
    run.rng_state = state["rng"]
    run.elapsed0 = run.history[-1]["seconds"] if run.history else 0.0
    if run.bar is not None:
        run.bar.update(state["epoch"])
