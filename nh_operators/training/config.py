"""What defines a training run: :class:`TrainConfig`, its validation, and the device."""

import dataclasses
from typing import Any, Literal

import torch

from ..data import PhysicsTerms
from ..models import model_config, training_defaults
from ..models.presets import ModelName, Preset, RecipeName, Variant
from .losses import LOSSES
from .schedulers import ExpHyperbolicLR, HyperbolicLR

__all__ = ["TrainConfig", "TrainingDiverged", "resolve_device"]

#: Learning-rate schedules by name (``TrainConfig.scheduler``); ``None``: a constant lr.
SCHEDULERS = {"exphyperbolic": ExpHyperbolicLR, "hyperbolic": HyperbolicLR,
              "constant": None}
#: The names of :data:`SCHEDULERS`.
SchedulerName = Literal["exphyperbolic", "hyperbolic", "constant"]


class TrainingDiverged(RuntimeError):
    """The training loss became non-finite; the last good checkpoint is kept."""


@dataclasses.dataclass
class TrainConfig:
    """Everything that defines a training run (saved in its checkpoint and config.json).

    Args:
        model: a key of :data:`nh_operators.MODELS`.
        preset: architecture preset, "paper" or "cpu".
        variant: "ours" (default) or "reference", the authors' networks
            (:data:`~nh_operators.models.VARIANTS`; not for FNO or PhaseONet).
        recipe: "ours" (default: the paper's TPE values, AdamW betas (0.85, 0.98), the
            schedule moved every iteration) or "reference" (as the authors' code ran it:
            their lr and infimum, betas (0.9, 0.999), the schedule moved once per
            epoch; :data:`~nh_operators.models.RECIPES`). It fills every value left
            ``None`` below; a value given wins.
        arch: constructor arguments replacing the preset's.
        epochs: number of epochs (also the schedule's ``max_iter``).
        seed: seed of the weights, the batch order and the VaRONet noise.
        batch_size: potentials per iteration (paper: 100).
        lr, upper_bound, infimum_lr, beta: schedule and KL weight; ``None`` takes the
            recipe's value for the model (see ``training_defaults``).
        scheduler: "exphyperbolic" (paper), "hyperbolic" or "constant".
        weight_decay: AdamW weight decay (default 0.01, PyTorch's).
        betas: AdamW betas (``None``: the recipe's; paper: (0.85, 0.98)).
        scheduler_step: "iteration" (the rate moves every iteration along the
            epoch-measured curve) or "epoch" (it holds within an epoch); ``None``: the
            recipe's.
        dtype: "float32" (default) or "float64".
        device: "auto" (CUDA when available), "cpu", "cuda", "cuda:1", ...
        amp: float16 autocast through DeepXDE's mixed mode; CUDA only.
        train_fraction: training part of the dataset's 80/20 split.
        loss: the loss the optimiser follows, "mse" (the paper's) or "logcosh" (see
            :mod:`~nh_operators.training.losses`); validation is always the MSE.
        ema: 0 (default) for none, or the cap of an exponential moving average of the
            weights with warm-up (:class:`~nh_operators.training.averaging.WeightAverage`;
            0.999 is a good value). The average is what validation scores and what
            the checkpoint's network (``load_model``) holds.
        physics: None (default: learn from the labels) or a dict of
            :class:`~nh_operators.data.PhysicsTerms` fields, e.g.
            ``{"label_fraction": 0.1, "energy": 0.1}``: learn from the residual of
            Hamilton's equations (with the labels of that share of the rows). In the
            default derivative form the network must be pointwise in time
            (``arch={"query_coupled": False}`` for the sequence networks; the
            ``"form": "integral"`` residual takes any network); it gets the starting
            state as an output transform, in training and wherever ``load_model``
            rebuilds it. Validation still scores against labels.
    """

    model: ModelName
    preset: Preset = "cpu"
    variant: Variant = "ours"
    recipe: RecipeName = "ours"
    arch: dict[str, Any] = dataclasses.field(default_factory=dict)
    epochs: int = 10
    seed: int = 0
    batch_size: int = 100
    lr: float | None = None
    upper_bound: float | None = None
    infimum_lr: float | None = None
    beta: float | None = None
    scheduler: SchedulerName = "exphyperbolic"
    weight_decay: float = 0.01
    betas: tuple[float, float] | None = None
    scheduler_step: Literal["iteration", "epoch"] | None = None
    dtype: Literal["float32", "float64"] = "float32"
    device: str = "auto"
    amp: bool = False
    train_fraction: float = 0.8
    loss: Literal["mse", "logcosh"] = "mse"
    ema: float = 0.0
    physics: dict[str, Any] | None = None

    def resolved(self) -> dict[str, Any]:
        """A plain dict with every default filled in, validated.

        Raises:
            ValueError: naming the first bad value.
        """
        cfg = dataclasses.asdict(self)
        cfg["arch"] = model_config(self.model, self.preset, self.variant, **self.arch)
        defaults = training_defaults(self.model, self.recipe)
        for key in ("lr", "upper_bound", "infimum_lr", "betas", "scheduler_step"):
            if cfg[key] is None:
                cfg[key] = defaults[key]
        if cfg["beta"] is None:
            cfg["beta"] = defaults.get("beta", 0.0)
        cfg["betas"] = list(cfg["betas"])
        if cfg["scheduler_step"] not in ("iteration", "epoch"):
            raise ValueError(f"scheduler_step must be 'iteration' or 'epoch', got "
                             f"{cfg['scheduler_step']!r}")
        if int(cfg["epochs"]) != cfg["epochs"] or cfg["epochs"] < 1:
            raise ValueError(f"epochs must be a positive integer, got {cfg['epochs']}")
        if int(cfg["batch_size"]) != cfg["batch_size"] or cfg["batch_size"] < 1:
            raise ValueError(f"batch_size must be a positive integer, got "
                             f"{cfg['batch_size']}")
        if cfg["scheduler"] not in SCHEDULERS:
            raise ValueError(f"unknown scheduler {cfg['scheduler']!r}; choose from "
                             f"{sorted(SCHEDULERS)}")
        if cfg["scheduler"] != "constant" and cfg["upper_bound"] < cfg["epochs"]:
            raise ValueError(f"upper_bound ({cfg['upper_bound']}) must be at least the "
                             f"number of epochs ({cfg['epochs']})")
        if cfg["dtype"] not in ("float32", "float64"):
            raise ValueError(f"dtype must be 'float32' or 'float64', got {cfg['dtype']!r}")
        if cfg["loss"] not in LOSSES:
            raise ValueError(f"unknown loss {cfg['loss']!r}; choose from {sorted(LOSSES)}")
        if not 0.0 <= cfg["ema"] < 1.0:
            raise ValueError(f"ema must be 0 (none) or a decay in (0, 1), got {cfg['ema']}")
        if cfg["physics"] is not None:
            try:
                cfg["physics"] = dataclasses.asdict(PhysicsTerms(**cfg["physics"]))
            except TypeError as err:
                raise ValueError(f"physics: {err} (fields: "
                                 f"{[f.name for f in dataclasses.fields(PhysicsTerms)]})"
                                 ) from None
        if not cfg["lr"] > 0:
            raise ValueError(f"lr must be positive, got {cfg['lr']}")
        return cfg


def resolve_device(device: str | torch.device = "auto") -> torch.device:
    """``torch.device`` for "auto" (CUDA when available, else CPU) or a device name.

    Raises:
        ValueError: if CUDA is asked for and not available.
    """
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    dev = torch.device(device)
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"device {device!r} asked for, but CUDA is not available")
    return dev
