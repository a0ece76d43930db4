"""Data: datasets of potentials with exact labels, on disk and for DeepXDE.

Generation in checksummed HDF5 chunks that resume, loading, and the operator data
that DeepXDE's training loop consumes. Imports the solvers, potentials and models.
"""

from .generate import PRESETS, Dataset, generate_dataset, label_potentials, load_dataset
from .operator_data import OperatorData

__all__ = [
    "PRESETS",
    "Dataset",
    "generate_dataset",
    "label_potentials",
    "load_dataset",
    "OperatorData",
]
