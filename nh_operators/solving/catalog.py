"""The shipped weights on disk: where they are and which models there are (torch-free)."""

from pathlib import Path

from ..training.files import CHECKPOINT

__all__ = ["WEIGHTS", "CALIBRATION", "available_pretrained"]

#: Folder of the shipped weights, one sub-folder per model.
WEIGHTS = Path(__file__).parent / "weights"
#: File of a shipped model's calibration, next to its weights.
CALIBRATION = "calibration.json"


def available_pretrained():
    """Names of the shipped models, sorted.

    Example:
        >>> "deeponet" in available_pretrained()
        True
    """
    if not WEIGHTS.is_dir():
        return []
    return sorted(p.name for p in WEIGHTS.iterdir() if (p / CHECKPOINT).is_file())
