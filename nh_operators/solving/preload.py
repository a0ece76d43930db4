"""Shipped networks loaded, and run once, before ``solve`` needs them.

Why: the first ``solve`` that picks a network otherwise pays for reading its weights
(tens of ms) and for a first forward (compiled kernels, torch's lazy setup), which can
cost more than the classical solve it was chosen to beat.
"""

import numpy as np

from .._constants import SENSORS
from .catalog import available_pretrained, resolve_pretrained
from .loader import load
from .network_pass import neural_raw
from .shipped import pretrained

__all__ = ["preload"]


def preload(names=None, warm=True):
    """Load shipped networks before the first ``solve`` asks for one, so that no call pays
    for reading weights (tens of ms each) or a first forward.

    Args:
        names: shipped model names (default: every one of
            :func:`~nh_operators.available_pretrained`).
        warm: also run each once on the harmonic well at one time (first-call costs:
            compiled kernels, torch's lazy setup).

    Returns:
        the names loaded, in order.

    Raises:
        ValueError: an unknown name, listing the available ones.

    Example:
        >>> preload(["phaseonet-paper"])
        ['phaseonet-paper']
    """
    names = list(available_pretrained() if names is None else names)
    loaded = []
    for name in names:
        name = resolve_pretrained(name)
        if name not in available_pretrained():
            pretrained(name)  # raises, naming the available ones
        shipped = load(name)
        _ = shipped.method  # reads the weights
        if warm:
            V = 2.0 - 8.0 * SENSORS * (1.0 - SENSORS)
            state = {"q0": 0.25, "p0": 0.5} if shipped.reads_state else {}
            neural_raw(name, V, "sensors", np.array([0.5]), **state)
        loaded.append(name)
    return loaded
