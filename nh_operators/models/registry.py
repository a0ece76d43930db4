"""The registry of networks: names, presets, construction and dtype casts."""

import inspect
from collections.abc import Mapping
from typing import Any, Literal, TypedDict

import torch

from ._layers import cast_module
from .deeponet import DeepONet
from .fno import FNO
from .mambonet import MambONet
from .phaseonet import phaseonet
from .presets import (ARCHITECTURES, PRESETS, REFERENCE_ARCHITECTURES,
                      REFERENCE_TRAINING, TRAINING, ModelName, Preset, RecipeName, Variant)
from .reference import REFERENCE_MODELS
from .traonet import TraONet
from .varonet import VaRONet

__all__ = ["MODELS", "PRESETS", "RECIPES", "VARIANTS", "build_model", "cast_network",
           "count_parameters", "model_config", "training_defaults"]

#: name → network class.
MODELS = {
    "deeponet": DeepONet,
    "traonet": TraONet,
    "varonet": VaRONet,
    "mambonet": MambONet,
    "fno": FNO,
    "phaseonet": phaseonet,  # PhaseONet, or StatePhaseONet with initial_state
}


#: variant → (name → class, preset → name → constructor arguments). "ours" (the
#: default): this project's networks; "reference": the authors' networks as their code
#: at 5c4cbd8 builds them (:func:`~nh_operators.models.from_reference`; no FNO).
VARIANTS = {
    "ours": (MODELS, ARCHITECTURES),
    "reference": (REFERENCE_MODELS, REFERENCE_ARCHITECTURES),
}


def _check(name, preset, variant="ours"):
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}; choose from {list(VARIANTS)}")
    models, architectures = VARIANTS[variant]
    if name not in models:
        raise ValueError(f"unknown model {name!r} for variant {variant!r}; choose from "
                         f"{sorted(models)}")
    if preset not in architectures:
        raise ValueError(f"unknown preset {preset!r}; choose from {list(PRESETS)}")
    return models[name], architectures[preset][name]


def model_config(name: ModelName, preset: Preset = "paper", variant: Variant = "ours",
                 **overrides: Any) -> dict[str, Any]:
    """The constructor arguments ``build_model`` would use.

    Raises:
        ValueError: for an unknown name, preset, variant or argument.
    """
    cls, preset_args = _check(name, preset, variant)
    allowed = set(inspect.signature(cls).parameters)
    if variant == "ours" and name == "phaseonet":
        _check_phaseonet(overrides)
        # the shared interface: built only for d = 1, uncoupled, which needs no argument
        overrides = {k: v for k, v in overrides.items()
                     if not (k in ("query_dim", "query_coupled") and k not in allowed)}
    unknown = sorted(set(overrides) - allowed)
    if unknown:
        raise ValueError(f"{name} has no argument(s) {unknown}; it takes {sorted(allowed)}")
    return {**preset_args, **overrides}


def _check_phaseonet(overrides: dict) -> None:
    """PhaseONet inverts the orbit of a 1-D Hamiltonian: say so for any other problem."""
    query_dim = overrides.get("query_dim", 1)
    n_outputs = overrides.get("n_outputs", 2)
    if query_dim != 1 or n_outputs not in (1, 2) or overrides.get("query_coupled"):
        raise ValueError(
            "phaseonet serves only the 1-D Hamiltonian problem of this package: query "
            "points are times t (query_dim=1) and the outputs q and p (n_outputs=2, or 1 "
            f"for q alone); got query_dim={query_dim}, n_outputs={n_outputs}. Choose "
            "deeponet, traonet, varonet, mambonet or fno for other operator problems")


def build_model(name: ModelName, preset: Preset = "paper", variant: Variant = "ours",
                **overrides: Any):
    """Build a network from the registry.

    Args:
        name: a key of :data:`MODELS` ("deeponet", "traonet", "varonet", "mambonet",
            "fno").
        preset: "paper" (the paper's optimal architecture) or "cpu" (small: an epoch
            of the standard dataset in under a minute on a 2-core CPU).
        variant: "ours" (default: this project's networks) or "reference" (the authors'
            networks as their code builds them, :data:`VARIANTS`; all but "fno").
        **overrides: constructor arguments replacing the preset's. Every network of
            "ours" takes ``n_sensors`` (m ≥ 1), ``n_outputs`` (k ≥ 1), ``query_dim``
            (d ≥ 1: query points of shape (M, d)), ``query_coupled`` (False: each
            query point is predicted on its own, and ``dde.grad`` derivatives are
            pointwise) and DeepXDE's ``regularization``. PhaseONet serves only the
            paper's problem (d = 1, k ≤ 2).

    Returns:
        The network, a ``deepxde.nn.pytorch.NN``, on the CPU in DeepXDE's default float
        (float32 unless ``dde.config.set_default_float`` said otherwise). Its weights
        come from torch's global generator: seed it (or use ``torch.random.fork_rng``)
        for reproducible weights.

    Raises:
        ValueError: for an unknown name, preset, variant or argument, or a problem the
            network cannot serve (PhaseONet with ``query_dim`` > 1 or 3 outputs).

    Example:
        >>> import torch
        >>> net = build_model("traonet", preset="cpu")
        >>> net((torch.zeros(2, 100), torch.zeros(5, 1))).shape
        torch.Size([2, 5, 2])
    """
    config = model_config(name, preset, variant, **overrides)
    return VARIANTS[variant][0][name](**config)


class Recipe(TypedDict):
    """A training recipe: the values by model, AdamW's betas, when the schedule moves."""

    values: Mapping[str, Mapping[str, float]]
    betas: tuple[float, float]
    scheduler_step: Literal["iteration", "epoch"]


#: Recipes: "ours" (the paper's TPE optimum, AdamW betas (0.85, 0.98), the schedule
#: moved every iteration) and "reference" (as the authors' code ran it).
RECIPES: dict[str, Recipe] = {
    "ours": {"values": TRAINING, "betas": (0.85, 0.98), "scheduler_step": "iteration"},
    "reference": {"values": REFERENCE_TRAINING, "betas": (0.9, 0.999),
                  "scheduler_step": "epoch"},
}


def training_defaults(name: ModelName, recipe: RecipeName = "ours") -> dict[str, Any]:
    """The training values of ``name`` in ``recipe``: lr, upper_bound, infimum_lr (and
    beta for VaRONet), betas and scheduler_step.

    Raises:
        ValueError: for an unknown model or recipe.

    Example:
        >>> training_defaults("traonet", "reference")["infimum_lr"]
        3.0497e-07
    """
    _check(name, "paper")
    if recipe not in RECIPES:
        raise ValueError(f"unknown recipe {recipe!r}; choose from {sorted(RECIPES)}")
    spec = RECIPES[recipe]
    values = spec["values"].get(name, TRAINING[name])
    return {**values, "betas": spec["betas"], "scheduler_step": spec["scheduler_step"]}


def count_parameters(net):
    """Number of trainable parameters of a network."""
    return sum(p.numel() for p in net.parameters() if p.requires_grad)


def cast_network(net, dtype):
    """Cast a network's real tensors to ``dtype`` and its complex ones to the matching
    complex dtype (``Module.to(dtype)`` would drop the imaginary part of FNO's
    spectral weights).

    Args:
        net: a ``torch.nn.Module``.
        dtype: ``torch.float32`` or ``torch.float64``.

    Returns:
        The same module, cast in place.
    """
    if dtype not in (torch.float32, torch.float64):
        raise ValueError(f"dtype must be torch.float32 or torch.float64, got {dtype}")
    return cast_module(net, dtype)
