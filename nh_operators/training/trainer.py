"""Training a network in DeepXDE's loop: AdamW, hyperbolic schedules, checkpoints, resume.

:func:`train` builds the network, wraps the dataset in an
:class:`~nh_operators.OperatorData`, compiles a ``dde.Model`` with an AdamW instance
(betas (0.85, 0.98)) and attaches the learning-rate schedule, which DeepXDE steps once
per *iteration*: the schedules take ``steps_per_epoch`` so that they follow the
per-epoch curve at fractional epochs. A DeepXDE callback ends every epoch with a
batched validation pass, a progress-bar update, a history row and an atomic checkpoint.
"""

import logging
import math
import time
from pathlib import Path

import numpy as np
import torch

from .._backend import ensure_pytorch_backend
from .._version import __version__
from ..models import build_model, cast_network, count_parameters
from .checkpoint import (
    CHECKPOINT,
    load_checkpoint,
    save_checkpoint,
    write_config,
    write_history,
)
from .config import SCHEDULERS, TrainingDiverged, resolve_device

dde = ensure_pytorch_backend()
log = logging.getLogger(__name__)

__all__ = ["train"]

class _EpochEnd(dde.callbacks.Callback):
    """Per-iteration bookkeeping and the end-of-epoch work (see :func:`train`)."""

    def __init__(self, run):
        super().__init__()
        self.run = run

    def on_train_begin(self):
        # DeepXDE's first display forward has run; put the RNG where the run left it.
        if self.run.rng_state is not None:
            _set_rng_state(self.run.rng_state, self.run.device)

    def on_batch_end(self):
        run = self.run
        run.data.advance()
        loss = run.data.last_loss
        run.epoch_losses.append(loss)
        if loss is None or not math.isfinite(loss):
            run.diverged = run.data.cursor
            self.model.stop_training = True
            return
        if run.data.cursor % run.steps == 0:
            run.end_epoch()


def _rng_state(device):
    state = {"torch": torch.get_rng_state()}
    if device.type == "cuda":
        state["cuda"] = torch.cuda.get_rng_state(device)
    return state


def _set_rng_state(state, device):
    torch.set_rng_state(state["torch"])
    if device.type == "cuda" and "cuda" in state:
        torch.cuda.set_rng_state(state["cuda"], device)


class _Run:
    """State of one training run shared by :func:`train` and its callback."""

    def __init__(self, cfg, out, net, data, model, scheduler, device, checksum,
                 progress, epoch_callback):
        self.cfg, self.out, self.net, self.data = cfg, out, net, data
        self.model, self.scheduler, self.device = model, scheduler, device
        self.checksum = checksum
        self.steps = data.steps_per_epoch(cfg["batch_size"])
        self.history, self.epoch_losses = [], []
        self.rng_state, self.diverged = None, None
        self.epoch_callback = epoch_callback
        self.t0 = time.perf_counter()
        self.elapsed0 = 0.0
        self.max_seconds = None
        self.bar = None
        if progress:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=cfg["epochs"], desc=f"train {cfg['model']}",
                            unit="epoch")

    @property
    def epoch(self):
        return self.data.cursor // self.steps

    def end_epoch(self):
        lr = self.model.opt.param_groups[0]["lr"]
        record = {
            "epoch": self.epoch,
            "train_loss": float(np.mean(self.epoch_losses)),
            "val_loss": self.data.validation_loss(self.net, self.cfg["batch_size"]),
            "lr": lr,
            "seconds": self.elapsed0 + time.perf_counter() - self.t0,
        }
        if not math.isfinite(record["val_loss"]):
            self.diverged = self.data.cursor
            self.model.stop_training = True
            return
        self.epoch_losses = []
        self.history.append(record)
        self.save()
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix(train=f"{record['train_loss']:.3e}",
                                 val=f"{record['val_loss']:.3e}", lr=f"{lr:.2e}")
        if self.epoch_callback is not None:
            self.epoch_callback(dict(record), self.net)
        if self.over_budget() and self.epoch < self.cfg["epochs"]:
            log.warning("stopping after epoch %d of %d: the run has used %.1f min of "
                        "its %.1f-minute budget (--resume with a larger one continues)",
                        self.epoch, self.cfg["epochs"], record["seconds"] / 60,
                        self.max_seconds / 60)
            self.model.stop_training = True

    def over_budget(self):
        return (self.max_seconds is not None and bool(self.history)
                and self.history[-1]["seconds"] >= self.max_seconds)

    def save(self):
        save_checkpoint(self.out, {
            "config": self.cfg,
            "model": self.net.state_dict(),
            "optimizer": self.model.opt.state_dict(),
            "scheduler": (None if self.scheduler is None
                          else self.scheduler.state_dict()),
            "epoch": self.epoch,
            "rng": _rng_state(self.device),
            "data_checksum": self.checksum,
            "history": self.history,
            "version": __version__,
        })
        write_history(self.out, self.history)


def _load_data(data):
    if isinstance(data, (str, Path)):
        from ..data import load_dataset

        return load_dataset(data)
    return data


def train(config, data, out, *, resume=False, progress=True, epoch_callback=None,
          max_minutes=None, stop_after=None):
    """Train a network through ``dde.Model`` and write a run directory.

    Args:
        config: a :class:`TrainConfig`.
        data: a :class:`~nh_operators.data.Dataset` or the path of its HDF5 file.
        out: run directory (created); holds ``checkpoint.pt``, ``config.json`` and
            ``history.csv`` (see :mod:`nh_operators.training.checkpoint`).
        resume: continue from ``out/checkpoint.pt`` when it exists. The config and the
            dataset checksum must match the checkpoint's; the run then ends exactly
            where an uninterrupted one would (on the same device).
        progress: show a progress bar (epoch, train and validation loss, lr, time).
        epoch_callback: called as ``epoch_callback(record, net)`` after each epoch's
            checkpoint, with the epoch's history record (a dict) and the network.
        max_minutes: wall-time budget in minutes, counted over the whole run (resumed
            parts included). Training stops after the first epoch that ends past it,
            with that epoch's checkpoint saved; ``--resume`` with a larger budget
            continues the same schedule. Not part of the config. ``None``: no limit.
        stop_after: stop after this epoch, with the schedule of ``config.epochs`` (how a
            run cut by ``max_minutes`` is reproduced on another machine).

    Returns:
        (network, history): the trained network (train mode) and a list of per-epoch
        dicts with epoch, train_loss, val_loss, lr and seconds.

    Raises:
        FileExistsError: ``out`` already holds a checkpoint and ``resume`` is false.
        ValueError: bad config, or a checkpoint that does not match it.
        TrainingDiverged: the loss became non-finite (the last good epoch's
            checkpoint stays in ``out``).

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
    device = resolve_device(cfg["device"])
    if cfg["amp"] and device.type != "cuda":
        raise ValueError("amp (float16 autocast) is only supported on CUDA")
    dataset = _load_data(data)
    checksum = dataset.checksum
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    state = None
    if (out / CHECKPOINT).exists():
        if not resume:
            raise FileExistsError(f"{str(out)!r} already holds a checkpoint; pass "
                                  "resume=True (--resume) or choose another folder")
        state = load_checkpoint(out, map_location=device)
        _check_resumable(state, cfg, checksum)
    write_config(out, cfg)

    dtype = getattr(torch, cfg["dtype"])
    with torch.random.fork_rng(devices=[device] if device.type == "cuda" else []):
        torch.manual_seed(cfg["seed"])
        net = build_model(cfg["model"], cfg["preset"], **cfg["arch"])
        net = cast_network(net, dtype).to(device)
        data_obj = dataset.to_deepxde(cfg["train_fraction"],
                                      dtype=np.float64 if cfg["dtype"] == "float64"
                                      else np.float32,
                                      beta=cfg["beta"], shuffle_seed=cfg["seed"],
                                      monitor_size=cfg["batch_size"])
        model = dde.Model(data_obj, net)
        opt = torch.optim.AdamW(net.parameters(), lr=cfg["lr"], betas=tuple(cfg["betas"]),
                                weight_decay=cfg["weight_decay"])
        steps = data_obj.steps_per_epoch(cfg["batch_size"])
        _untimed(dde.Model.compile)(model, opt, loss="mse", verbose=0)
        sched_cls = SCHEDULERS[cfg["scheduler"]]
        scheduler = None if sched_cls is None else sched_cls(
            opt, cfg["upper_bound"], cfg["epochs"], cfg["infimum_lr"],
            steps_per_epoch=steps)
        model.lr_scheduler = scheduler
        run = _Run(cfg, out, net, data_obj, model, scheduler, device, checksum,
                   progress, epoch_callback)
        run.max_seconds = None if max_minutes is None else 60.0 * max_minutes
        if state is not None:
            _restore(run, state)
        last = cfg["epochs"] if stop_after is None else int(stop_after)
        remaining = max(0, last * steps - data_obj.cursor)
        if run.over_budget():
            log.warning("the run has used %.1f of its %.1f minutes; nothing to do",
                        run.history[-1]["seconds"] / 60, max_minutes)
            remaining = 0
        log.info("training %s (%d parameters) on %s for %d iterations",
                 cfg["model"], count_parameters(net), device, remaining)
        try:
            if remaining > 0:
                _fit(model, run, remaining)
        finally:
            if run.bar is not None:
                run.bar.close()
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
                                      callbacks=[_EpochEnd(run)], verbose=0)
    finally:
        dde.config.mixed = mixed


def _check_resumable(state, cfg, checksum):
    old = dict(state["config"])
    if old != cfg:
        diff = sorted(k for k in set(old) | set(cfg) if old.get(k) != cfg.get(k))
        raise ValueError(f"cannot resume: the checkpoint's config differs in {diff}")
    if state.get("data_checksum") != checksum:
        raise ValueError("cannot resume: the dataset differs from the checkpoint's "
                         "(checksum mismatch)")


def _restore(run, state):
    run.net.load_state_dict(state["model"])
    run.model.opt.load_state_dict(state["optimizer"])
    if run.scheduler is not None:
        run.scheduler.load_state_dict(state["scheduler"])
    run.data.cursor = state["epoch"] * run.steps
    run.history = list(state["history"])
    run.rng_state = state["rng"]
    run.elapsed0 = run.history[-1]["seconds"] if run.history else 0.0
    if run.bar is not None:
        run.bar.update(state["epoch"])
