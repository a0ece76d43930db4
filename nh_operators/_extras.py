"""Optional dependencies: import one, or say which extra of the package installs it."""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["EXTRAS", "require"]

#: module → (extra of nh-operators that installs it, what needs it).
EXTRAS: dict[str, tuple[str, str]] = {
    "neuralop": ("fno", "the FNO network"),
    "optuna": ("tune", "hyper-parameter tuning (nh-operators tune)"),
}


def require(module: str) -> ModuleType:
    """Import an optional dependency.

    Args:
        module: a key of :data:`EXTRAS` (``"neuralop"``, ``"optuna"``), or one of its
            submodules (``"neuralop.models"``).

    Returns:
        The imported module.

    Raises:
        ImportError: when it is not installed, naming the extra that installs it.

    Example:
        >>> require("optuna").__name__
        'optuna'
    """
    top = module.split(".")[0]
    if top not in EXTRAS:
        raise ValueError(f"{top!r} is not an optional dependency; choose from {sorted(EXTRAS)}")
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as err:
        if err.name is None or err.name.split(".")[0] != top:
            raise
        extra, needs = EXTRAS[top]
        raise ImportError(f"{needs} needs the optional package {top!r}: install it with "
                          f"pip install 'nh-operators[{extra}]'") from err
