"""Models: the neural operators as DeepXDE networks, and batched prediction.

DeepONet, TraONet, VaRONet, MambONet and an FNO baseline, the authors' versions of the
first four (the ``reference`` variant, :func:`from_reference`), the registry that builds
them from presets, and :func:`predict`. A bottom wing: it imports no other wing.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "deeponet": ["DeepONet"],
    "fno": ["FNO"],
    "inference": ["as_network", "batched_forward", "predict"],
    "mambonet": ["MambONet"],
    "reference": ["REFERENCE_MODELS", "from_reference", "reference_arguments"],
    "reference_nets": ["ReferenceDeepONet", "ReferenceVaRONet"],
    "reference_transformers": ["ReferenceMambONet", "ReferenceTraONet"],
    "registry": ["MODELS", "PRESETS", "VARIANTS", "build_model", "cast_network",
                 "count_parameters", "model_config", "training_defaults"],
    "traonet": ["TraONet"],
    "varonet": ["VaRONet"],
})
