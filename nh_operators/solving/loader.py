"""The shipped networks as typed objects, loaded once: :func:`load` returns a
:class:`ShippedNetwork`.

This module holds the package's one cache of shipped networks (``_LOADED`` and
``_NETWORKS`` below, cleared by :func:`forget`): what :func:`load` read from
``weights/NAME`` (domain, state flag, calibration: torch-free) and, on first use, the
network itself. Entries are never changed once made; two threads that load the same
name at once may both read it, and one answer is kept.

To add a shipped network: put its folder under ``nh_operators/solving/weights/NAME``
(:func:`~nh_operators.export_pretrained`, then ``nh-operators calibrate``); nothing else
names it. Weights exported while a process runs are seen from then on.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .calibration import Calibration
from .catalog import CALIBRATION, WEIGHTS, network_domain, reads_state, refresh, shipped_names

if TYPE_CHECKING:
    from ..evaluation import NeuralMethod

__all__ = ["ShippedNetwork", "forget", "load", "shipped_names", "with_calibration"]


@dataclass(frozen=True, eq=False)
class ShippedNetwork:
    """A shipped network with what ``solve`` needs to use it.

    Attributes:
        name: its folder under ``weights/`` (``"phaseonet-paper"``).
        domain: the inputs it was trained on, as bounds at the sensors
            (:func:`~nh_operators.solving.network_domain`).
        reads_state: whether it reads (q0, p0) after the sensors.
        calibration: its :class:`~nh_operators.solving.calibration.Calibration`, or None
            (then ``auto`` never chooses it and its estimate is the raw one).

    The network itself (:attr:`method`, :attr:`net`) is read on first use (it needs
    torch), once per process.

    Example:
        >>> shipped = load("traonet-paper")
        >>> shipped.reads_state, shipped.calibration is not None
        (False, True)
    """

    name: str
    domain: dict[str, Any]
    reads_state: bool
    calibration: Calibration | None

    @property
    def method(self) -> NeuralMethod:
        """The network as :func:`~nh_operators.pretrained` returns it (loaded once)."""
        method = _NETWORKS.get(self.name)
        if method is None:
            from .shipped import pretrained

            method = _NETWORKS.setdefault(self.name, pretrained(self.name))
        return method

    @property
    def net(self) -> Any:
        """The torch module (``self.method.net``)."""
        return self.method.net

    def input_rows(self, V: np.ndarray, q0: Any = 0.0, p0: Any = 0.0) -> np.ndarray:
        """The network's input rows: the sensor values V (N, 100), then (q0, p0) (scalars
        or (N,)) for a network that reads a state: (N, 100) or (N, 102)."""
        if not self.reads_state:
            return V
        n = len(V)
        return np.column_stack([V, np.broadcast_to(q0, (n,)), np.broadcast_to(p0, (n,))])


#: The cache: what :func:`load` read, by name.
_LOADED: dict[str, ShippedNetwork] = {}
#: The cache: the networks themselves, by name (read on first use).
_NETWORKS: dict[str, NeuralMethod] = {}


def load(name: str) -> ShippedNetwork:
    """Shipped network ``name`` (a folder name, as :func:`shipped_names` lists it), read
    once per process; torch-free until its network is used.

    Raises:
        ValueError: a name that is not shipped, or a calibration file this version
            cannot read.
    """
    shipped = _LOADED.get(name)
    if shipped is None:
        if name not in shipped_names():
            raise ValueError(f"no pretrained model {name!r}; available: "
                             f"{list(shipped_names()) or 'none'}")
        path = WEIGHTS / name / CALIBRATION
        calibration = Calibration.read(path) if path.is_file() else None
        shipped = _LOADED.setdefault(name, ShippedNetwork(
            name, network_domain(name), reads_state(name), calibration))
    return shipped


def forget(name: str | None = None) -> None:
    """Empty the cache (of ``name`` only, if given) and read the list of shipped
    networks again: after weights or a calibration changed on disk."""
    for cache in (_LOADED, _NETWORKS):
        if name is None:
            cache.clear()
        else:
            cache.pop(name, None)
    refresh()


def with_calibration(name: str, calibration: Calibration | None) -> ShippedNetwork:
    """Use ``calibration`` for shipped network ``name`` from now on in this process (its
    network stays loaded): for a calibration written elsewhere
    (:func:`~nh_operators.solving.calibrate_pretrained`'s ``out``) or a what-if study.
    :func:`forget` goes back to the shipped file.

    Returns:
        the new :class:`ShippedNetwork`.
    """
    shipped = replace(load(name), calibration=calibration)
    _LOADED[name] = shipped
    return shipped
