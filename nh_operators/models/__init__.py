"""Models: the neural operators as DeepXDE networks, and batched prediction.

DeepONet, TraONet, VaRONet, MambONet, an FNO baseline, PhaseONet (a fast operator
built for cost per trajectory, not one of the paper's), the authors' versions of the
first four (the ``reference`` variant, :func:`from_reference`), the registry that builds
them from presets, and :func:`predict`. A bottom wing: it imports no other wing.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "deeponet": ["DeepONet"],
    "fno": ["FNO"],
    "inference": ["as_network", "batched_forward", "predict"],
    "kl_data": ["KLData"],
    "mambonet": ["MambONet"],
    "phase_rules": ["period_quadrature"],
    "phaseonet": ["PhaseONet"],
    "reference": ["REFERENCE_MODELS", "from_reference", "reference_arguments"],
    "reference_nets": ["ReferenceDeepONet", "ReferenceVaRONet"],
    "reference_transformers": ["ReferenceMambONet", "ReferenceTraONet"],
    "registry": ["MODELS", "PRESETS", "RECIPES", "VARIANTS", "build_model", "cast_network",
                 "count_parameters", "model_config", "training_defaults"],
    "state_phaseonet": ["StatePhaseONet"],
    "traonet": ["TraONet"],
    "varonet": ["VaRONet"],
})
