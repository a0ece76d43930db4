"""Training: DeepXDE's loop with the paper's recipe, checkpoints and tuning.

Imports data, models, solvers and potentials.
"""

from .checkpoint import (
    CHECKPOINT,
    load_checkpoint,
    load_model,
    save_checkpoint,
    write_atomic,
    write_history,
)
from .config import TrainConfig, TrainingDiverged, resolve_device
from .schedulers import ExpHyperbolicLR, HyperbolicLR, adjusted_infimum_lr
from .trainer import train
from .training_plots import minutes_to_reach, plot_training_curves, read_history
from .tuning import TrialReporter, tune
from .tuning_spaces import (
    SEARCH_SPACES,
    STAGES,
    TUNED_KEYS,
    get_space,
    grid_size,
    load_tuned_config,
    stage_params,
    tuned_train_kwargs,
)
from .tuning_study import (
    DEFAULT_STORAGE,
    best_config,
    open_storage,
    open_study,
    study_name,
    write_best_config,
)

__all__ = [
    "HyperbolicLR",
    "ExpHyperbolicLR",
    "adjusted_infimum_lr",
    "CHECKPOINT",
    "load_checkpoint",
    "load_model",
    "write_atomic",
    "save_checkpoint",
    "write_history",
    "TrainConfig",
    "TrainingDiverged",
    "train",
    "resolve_device",
    "read_history",
    "plot_training_curves",
    "minutes_to_reach",
    "SEARCH_SPACES",
    "STAGES",
    "TUNED_KEYS",
    "get_space",
    "stage_params",
    "grid_size",
    "load_tuned_config",
    "tuned_train_kwargs",
    "DEFAULT_STORAGE",
    "best_config",
    "open_storage",
    "open_study",
    "study_name",
    "write_best_config",
    "TrialReporter",
    "tune",
]
