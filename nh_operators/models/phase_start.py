"""Where PhaseONet's half-orbit starts before the MLP's correction: a small strategy.

PhaseONet predicts the half-orbit Q(h), P(h) on a grid of the half-phase as a start plus
the MLP's correction in a trainable basis. Two starts:

* :class:`HarmonicStart` (``"learned"``): the harmonic orbit (1 − cos 2πh)/2 (and, from a
  state, π sin 2πh for P); the MLP learns the whole shape.
* :class:`QuadratureStart` (``"quadrature"``): the shape computed by inverting the phase
  integral on the period's own rule (:mod:`.orbit_shape`: a classical solve of the orbit
  in the sensor spline); the MLP learns a correction that starts at zero (its last layer
  is zero at construction).

The names are for configs and the command line (``--arch shape=quadrature``);
:func:`start_shape` turns one into its object.
"""

import abc
import dataclasses
from collections.abc import Sequence
from typing import ClassVar, Literal

import torch

from .phase_rules import RestQuadrature

__all__ = ["START_SHAPES", "HarmonicStart", "QuadratureStart", "StartShape", "start_shape"]

Tensor = torch.Tensor


class StartShape(abc.ABC):
    """Abstract start of the half-orbit: the tables the MLP's correction is added to."""

    #: The name in configs.
    name: ClassVar[str]
    #: Whether the MLP's last layer starts at zero (the start is already the answer).
    zero_correction: ClassVar[bool]

    @abc.abstractmethod
    def at_rest(self, quadrature: RestQuadrature, V: Tensor, grid: int,
                harmonic: Sequence[Tensor]) -> tuple[Tensor, tuple[Tensor, ...]]:
        """The period and the start tables of the rest scene.

        Args:
            quadrature: the network's rule.
            V: (B, m) sensor values.
            grid: nodes of the half-phase.
            harmonic: the network's harmonic tables, one (grid,) per output.

        Returns:
            (T (B,) float64, one table per output, (grid,) or (B, grid)).
        """

    @abc.abstractmethod
    def shape_grid(self, grid: int) -> int:
        """The nodes of the shape to compute from a state (0: none)."""

    @abc.abstractmethod
    def from_state(self, orbit: dict[str, Tensor],
                   harmonic: Sequence[Tensor]) -> tuple[Tensor, ...]:
        """The start tables from a state, given the orbit's coordinates (with Q and P when
        :meth:`shape_grid` is positive) and the network's harmonic tables."""


@dataclasses.dataclass(frozen=True)
class HarmonicStart(StartShape):
    """Start at the harmonic orbit; the MLP learns the whole shape (``"learned"``).

    Example:
        >>> HarmonicStart().shape_grid(256)
        0
    """

    name: ClassVar[str] = "learned"
    zero_correction: ClassVar[bool] = False

    def at_rest(self, quadrature: RestQuadrature, V: Tensor, grid: int,
                harmonic: Sequence[Tensor]) -> tuple[Tensor, tuple[Tensor, ...]]:
        return quadrature.period(V), tuple(harmonic)

    def shape_grid(self, grid: int) -> int:
        return 0

    def from_state(self, orbit: dict[str, Tensor],
                   harmonic: Sequence[Tensor]) -> tuple[Tensor, ...]:
        return tuple(harmonic)


@dataclasses.dataclass(frozen=True)
class QuadratureStart(StartShape):
    """Start at the shape computed from the period's rule; the MLP learns a correction
    that starts at zero (``"quadrature"``).

    Example:
        >>> QuadratureStart().shape_grid(256)
        256
    """

    name: ClassVar[str] = "quadrature"
    zero_correction: ClassVar[bool] = True

    def at_rest(self, quadrature: RestQuadrature, V: Tensor, grid: int,
                harmonic: Sequence[Tensor]) -> tuple[Tensor, tuple[Tensor, ...]]:
        # the tables in the network's dtype (its harmonic tables'): no cast later
        T, Q, P = quadrature.rest_shape(V, grid, harmonic[0].dtype)
        return T, (Q, P)[:len(harmonic)]

    def shape_grid(self, grid: int) -> int:
        return grid

    def from_state(self, orbit: dict[str, Tensor],
                   harmonic: Sequence[Tensor]) -> tuple[Tensor, ...]:
        return (orbit["Q"], orbit["P"])[:len(harmonic)]


#: Config name → start.
START_SHAPES: dict[str, type[StartShape]] = {"learned": HarmonicStart,
                                              "quadrature": QuadratureStart}


def start_shape(shape: "StartShape | Literal['learned', 'quadrature']") -> StartShape:
    """The start object of a config name (an object is returned as it is).

    Raises:
        ValueError: for an unknown name.

    Example:
        >>> start_shape("quadrature")
        QuadratureStart()
    """
    if isinstance(shape, StartShape):
        return shape
    if not isinstance(shape, str) or shape not in START_SHAPES:
        raise ValueError(f"shape must be 'learned' or 'quadrature' (or a StartShape), got "
                         f"{shape!r}")
    return START_SHAPES[shape]()
