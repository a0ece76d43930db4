"""Training: DeepXDE's loop with the paper's recipe, checkpoints and tuning.

Imports data, models, solvers and potentials.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "averaging": ["WeightAverage"],
    "losses": ["LOSSES", "log_cosh"],
    "checkpoint": ["load_checkpoint", "load_model", "network_from_config", "save_checkpoint",
                   "write_history"],
    "files": ["CHECKPOINT", "CONFIG", "HISTORY", "write_atomic"],
    "config": ["TrainConfig", "TrainingDiverged", "resolve_device"],
    "distributed": ["Distributed", "RankFailed", "init_distributed"],
    "newton_refinement": ["refine_newton"],
    "refinement": ["refine"],
    "refinement_result": ["Refinement"],
    "schedulers": ["ExpHyperbolicLR", "HyperbolicLR", "adjusted_infimum_lr"],
    "trainer": ["train"],
    "training_plots": ["minutes_to_reach", "plot_training_curves", "read_history"],
    "tuning": ["TrialReporter", "tune"],
    "tuning_spaces": ["SEARCH_SPACES", "STAGES", "TUNED_KEYS", "get_space", "grid_size",
                      "load_tuned_config", "stage_params", "tuned_train_kwargs"],
    "tuning_study": ["DEFAULT_STORAGE", "best_config", "open_storage", "open_study",
                     "study_name", "write_best_config"],
})
