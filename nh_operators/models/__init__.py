"""Models: the neural operators as DeepXDE networks, and batched prediction.

DeepONet, TraONet, VaRONet, MambONet and an FNO baseline, the registry that builds them
from presets, and :func:`predict`. A bottom wing: it imports no other wing.
"""

from .deeponet import DeepONet
from .fno import FNO
from .inference import as_network, batched_forward, predict
from .mambonet import MambONet
from .registry import (
    MODELS,
    PRESETS,
    build_model,
    cast_network,
    count_parameters,
    model_config,
    training_defaults,
)
from .traonet import TraONet
from .varonet import VaRONet

__all__ = [
    "DeepONet",
    "TraONet",
    "VaRONet",
    "MambONet",
    "FNO",
    "MODELS",
    "PRESETS",
    "build_model",
    "cast_network",
    "model_config",
    "training_defaults",
    "count_parameters",
    "predict",
    "as_network",
    "batched_forward",
]
