"""The registry of networks: names, presets, construction and dtype casts."""

import inspect

import torch

from .deeponet import DeepONet
from .fno import FNO
from .mambonet import MambONet
from .phaseonet import PhaseONet
from .presets import (ARCHITECTURES, PRESETS, REFERENCE_ARCHITECTURES,
                      REFERENCE_TRAINING, TRAINING)
from .reference import REFERENCE_MODELS
from .traonet import TraONet
from .varonet import VaRONet

__all__ = ["MODELS", "PRESETS", "RECIPES", "VARIANTS", "build_model", "cast_network", "model_config",
           "training_defaults", "count_parameters"]

#: name → network class.
MODELS = {
    "deeponet": DeepONet,
    "traonet": TraONet,
    "varonet": VaRONet,
    "mambonet": MambONet,
    "fno": FNO,
    "phaseonet": PhaseONet,
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


def model_config(name, preset="paper", variant="ours", **overrides):
    """The constructor arguments ``build_model`` would use.

    Raises:
        ValueError: for an unknown name, preset, variant or argument.
    """
    cls, preset_args = _check(name, preset, variant)
    allowed = set(inspect.signature(cls).parameters)
    unknown = sorted(set(overrides) - allowed)
    if unknown:
        raise ValueError(f"{name} has no argument(s) {unknown}; it takes {sorted(allowed)}")
    return {**preset_args, **overrides}


def build_model(name, preset="paper", variant="ours", **overrides):
    """Build a network from the registry.

    Args:
        name: a key of :data:`MODELS` ("deeponet", "traonet", "varonet", "mambonet",
            "fno").
        preset: "paper" (the paper's optimal architecture) or "cpu" (small: an epoch
            of the standard dataset in under a minute on a 2-core CPU).
        variant: "ours" (default: this project's networks) or "reference" (the authors'
            networks as their code builds them, :data:`VARIANTS`; all but "fno").
        **overrides: constructor arguments replacing the preset's.

    Returns:
        The network, a ``deepxde.nn.pytorch.NN``, in float32 on the CPU. Its weights
        come from torch's global generator: seed it (or use ``torch.random.fork_rng``)
        for reproducible weights.

    Raises:
        ValueError: for an unknown name, preset, variant or argument.

    Example:
        >>> import torch
        >>> net = build_model("traonet", preset="cpu")
        >>> net((torch.zeros(2, 100), torch.zeros(5, 1))).shape
        torch.Size([2, 5, 2])
    """
    config = model_config(name, preset, variant, **overrides)
    return VARIANTS[variant][0][name](**config)


#: Recipes: "ours" (the paper's TPE optimum, AdamW betas (0.85, 0.98), the schedule
#: moved every iteration) and "reference" (as the authors' code ran it).
RECIPES = {
    "ours": dict(values=TRAINING, betas=(0.85, 0.98), scheduler_step="iteration"),
    "reference": dict(values=REFERENCE_TRAINING, betas=(0.9, 0.999),
                      scheduler_step="epoch"),
}


def training_defaults(name, recipe="ours"):
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
    complex_dtype = {torch.float32: torch.complex64, torch.float64: torch.complex128}
    if dtype not in complex_dtype:
        raise ValueError(f"dtype must be torch.float32 or torch.float64, got {dtype}")

    def cast(t):
        if t.is_complex():
            return t.to(complex_dtype[dtype])
        return t.to(dtype) if t.is_floating_point() else t

    return net._apply(cast)
