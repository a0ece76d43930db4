"""Models: the neural operators as DeepXDE networks, and batched prediction.

DeepONet, TraONet, VaRONet, MambONet and an FNO baseline, the registry that builds them
from presets, and :func:`predict`. A bottom wing: it imports no other wing.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "deeponet": ["DeepONet"],
    "fno": ["FNO"],
    "inference": ["as_network", "batched_forward", "predict"],
    "mambonet": ["MambONet"],
    "registry": ["MODELS", "PRESETS", "build_model", "cast_network", "count_parameters",
                 "model_config", "training_defaults"],
    "traonet": ["TraONet"],
    "varonet": ["VaRONet"],
})
