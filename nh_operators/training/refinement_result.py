"""What a test-time refinement returns (:func:`~nh_operators.refine`, either method)."""

from __future__ import annotations

import dataclasses

import numpy as np
import torch

__all__ = ["Refinement"]


@dataclasses.dataclass(frozen=True)
class Refinement:
    """What :func:`refine` returns.

    Attributes:
        q, p: (M,) the refined trajectory at the asked times (float64).
        residual_before, residual_after: mean squared residual (both equations, averaged)
            at the collocation times, before and after the steps.
        steps: optimisation steps taken.
        seconds: wall time of the refinement (copy, steps and prediction).
        net: the refined copy (float64); the given network is unchanged. None for
            ``method="newton"``, which refines the trajectory, not the network.
        estimate: ``method="newton"``: the collocation's error estimate (the size of
            the trajectory's last Chebyshev coefficients); None for the weights.
        converged: ``method="newton"``: whether the estimate met ``tol``; None for the
            weights.
    """

    q: np.ndarray
    p: np.ndarray
    residual_before: float
    residual_after: float
    steps: int
    seconds: float
    net: torch.nn.Module | None
    estimate: float | None = None
    converged: bool | None = None
