"""The state of a training run and the DeepXDE callback that ends each epoch.

:class:`TrainingRun` holds what :func:`~nh_operators.training.train` and its callback share;
:class:`EpochEnd` advances the data's cursor after every DeepXDE iteration and ends an
epoch with the validation pass, a history record, the checkpoint and the progress bar.
In a distributed run (:class:`~nh_operators.training.distributed.Distributed`) every
rank runs the same callback: the training loss of each iteration and the validation
sums are added over the ranks, so every rank takes the same decisions (divergence,
wall-time budget) at the same iteration, and rank 0 alone writes and draws.
"""

import contextlib
import logging
import math
import time
from typing import Any

import numpy as np
import torch

from .._backend import ensure_pytorch_backend
from .._version import __version__
from .averaging import WeightAverage
from .checkpoint import save_checkpoint, write_history

dde: Any = ensure_pytorch_backend()  # deepxde ships no type information
log = logging.getLogger(__name__)

__all__ = []


def _rng_state(device):
    state = {"torch": torch.get_rng_state()}
    if device.type == "cuda":
        state["cuda"] = torch.cuda.get_rng_state(device)
    return state


def _set_rng_state(state, device):
    torch.set_rng_state(state["torch"])
    if device.type == "cuda" and "cuda" in state:
        torch.cuda.set_rng_state(state["cuda"], device)


class EpochEnd(dde.callbacks.Callback):
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
        if run.dist.active:  # the mean over the global batch (see ShardedOperatorData)
            local = math.nan if loss is None else loss
            loss = float(run.dist.sum([local])[0]) / run.dist.world_size
        run.epoch_losses.append(loss)
        if run.average is not None:
            run.average.update(run.net)
        if loss is None or not math.isfinite(loss):
            run.diverged = run.data.cursor
            self.model.stop_training = True
            return
        if run.data.cursor % run.steps == 0:
            run.end_epoch()


class TrainingRun:
    """State of one training run shared by :func:`train` and its callback."""

    def __init__(self, cfg, out, net, data, model, scheduler, dist, checksum,
                 progress, epoch_callback):
        self.cfg, self.out, self.net, self.data = cfg, out, net, data
        self.model, self.scheduler, self.dist = model, scheduler, dist
        self.device = dist.device
        self.checksum = checksum
        # the draw version of the training data (1: before draw 2, bytes CPU-dependent)
        self.draw = int(data.rows.generator.get("draw", 1))
        self.steps = data.steps_per_epoch(cfg["batch_size"])
        self.history, self.epoch_losses = [], []
        self.rng_state, self.diverged = None, None
        self.epoch_callback = epoch_callback
        self.t0 = time.perf_counter()
        self.elapsed0 = 0.0
        self.max_seconds: float | None = None
        self.bar = None
        self.average: WeightAverage | None = None  # one when cfg["ema"]
        if progress and dist.is_main:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=cfg["epochs"], desc=f"train {cfg['model']}",
                            unit="epoch")

    @property
    def epoch(self):
        return self.data.cursor // self.steps

    @property
    def last_saved(self):
        """The epoch of the last checkpoint (0: none)."""
        return self.history[-1]["epoch"] if self.history else 0

    def scored(self):
        """Context in which ``self.net`` holds the weights that are scored and saved
        (the average when there is one)."""
        if self.average is None:
            return contextlib.nullcontext(self.net)
        return self.average.applied(self.net)

    def end_epoch(self):
        lr = self.model.opt.param_groups[0]["lr"]
        with self.scored() as net:
            total, count = self.data.validation_sums(net, self.cfg["batch_size"])
        seconds = self.elapsed0 + time.perf_counter() - self.t0
        if self.dist.active:  # validation shards added up; rank 0's clock for everyone
            total, count, seconds = self.dist.sum(
                [total, count, seconds if self.dist.is_main else 0.0])
        record = {
            "epoch": self.epoch,
            "train_loss": float(np.mean(self.epoch_losses)),
            "val_loss": float(total / count),
            "lr": lr,
            "seconds": float(seconds),
        }
        if not math.isfinite(record["val_loss"]):
            self.diverged = self.data.cursor
            self.model.stop_training = True
            return
        self.epoch_losses = []
        self.history.append(record)
        if self.dist.is_main:
            self.save()
        self.dist.barrier()  # the checkpoint exists before any rank goes on
        self.dist.maybe_fail(self.epoch)
        if self.bar is not None:
            self.bar.update(1)
            self.bar.set_postfix(train=f"{record['train_loss']:.3e}",
                                 val=f"{record['val_loss']:.3e}", lr=f"{lr:.2e}")
        if self.epoch_callback is not None:
            with self.scored() as net:
                self.epoch_callback(dict(record), net)
        budget = self.max_seconds
        if budget is not None and self.over_budget() and self.epoch < self.cfg["epochs"]:
            if self.dist.is_main:
                log.warning("stopping after epoch %d of %d: the run has used %.1f min of "
                            "its %.1f-minute budget (--resume with a larger one "
                            "continues)", self.epoch, self.cfg["epochs"],
                            record["seconds"] / 60, budget / 60)
            self.model.stop_training = True

    def over_budget(self):
        return (self.max_seconds is not None and bool(self.history)
                and self.history[-1]["seconds"] >= self.max_seconds)

    def save(self):
        extra = {}
        if self.average is not None:  # "model" is what load_model gives: the average
            extra = {"train_model": self.net.state_dict(),
                     "average": self.average.state_dict()}
        save_checkpoint(self.out, {
            **extra,
            "config": self.cfg,
            "model": (self.net.state_dict() if self.average is None
                      else self.average.shadow),
            "optimizer": self.model.opt.state_dict(),
            "scheduler": (None if self.scheduler is None
                          else self.scheduler.state_dict()),
            "epoch": self.epoch,
            "rng": _rng_state(self.device),
            "data_checksum": self.checksum,
            "data_draw": self.draw,
            "train_rows": self.data.n_train,
            "history": self.history,
            "version": __version__,
        })
        write_history(self.out, self.history)
