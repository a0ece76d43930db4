"""Data: datasets of potentials with exact labels, on disk and for DeepXDE.

Generation in checksummed HDF5 chunks that resume, loading, and the operator data
that DeepXDE's training loop consumes. Imports the solvers, potentials and models.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "_h5": ["dataset_attrs", "partial_progress"],
    "generate": ["DATASET_PRESETS", "Dataset", "check_output_path", "generate_dataset",
                 "label_potentials", "load_dataset", "preset_kwargs"],
    "operator_data": ["OperatorData"],
    "physics_loss": ["PhysicsTerms", "integral_residuals"],
    "physics_terms": ["SensorSpline", "state_transform", "time_derivative"],
    "rows": ["H5Rows", "MemoryRows", "Rows", "open_rows", "split_indices"],
    "shards": ["ShardedOperatorData", "check_global_batch", "shard_bounds"],
})
