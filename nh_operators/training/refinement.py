"""Test-time refinement: lower a network's residual of Hamilton's equations on one potential.

What: :func:`refine` copies a pointwise network, and takes a few optimisation steps on the
mean squared residual of dq/dt = p, dp/dt = −V'(q) for the one potential asked about,
then predicts with the copy. No labels and no solver are used.

The math: the copy works in float64. Its outputs are shifted so that the starting state
holds exactly, q(t) = q0 + y_q(t) − y_q(0) (likewise p), which keeps what the network
predicted and its derivative. V' comes from a not-a-knot cubic spline: of the 100 sensor
values, or, for a potential known as a function, of ``knots`` samples of it (so the
refined trajectory converges to the potential's own, not to its sensors').

Why: a network is fast but off by its training error; a residual can be evaluated on any
potential, including ones outside the training distribution. Whether the extra steps pay
against a classical solver at the refined accuracy is measured by
``benchmarks/physics/refine.py``.
"""

from __future__ import annotations

import copy
import time
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np
import torch

from .._constants import SENSORS, TIMES
from ..data import SensorSpline, time_derivative
from ..models import cast_network
from .refinement_result import Refinement

__all__ = ["Refinement", "refine"]


def refine(model: Any, potential: Any, t: np.ndarray = TIMES, *, steps: int = 100,
           lr: float = 1e-4, optimizer: Literal["adam", "lbfgs"] = "adam",
           q0: float = 0.0, p0: float = 0.0, collocation: int = 200,
           knots: int = 1000, parameters: Sequence[str] | None = None,
           method: Literal["weights", "newton"] = "weights", tol: float = 1e-10
           ) -> Refinement:
    """Refine a network's prediction on one potential by lowering its residual.

    Two methods. ``"weights"`` (default) takes ``steps`` optimiser steps on a float64 copy
    of the network. ``"newton"`` keeps the network and refines its trajectory: the
    prediction is the first guess of a Chebyshev collocation solve, driven by Newton's
    method to ``tol`` (:func:`~nh_operators.training.refine_newton`; ``steps``, ``lr``,
    ``optimizer``, ``parameters`` and ``collocation`` do not apply to it).

    Args:
        model: a pointwise network (``query_coupled`` False), or a method holding one in
            ``.net`` (``nh.pretrained(name)``). It is not modified.
        potential: 100 sensor values (the residual then uses their spline), or a
            potential with a vectorised ``V(q)`` (a physical potential, a
            :class:`~nh_operators.BoundedPotential`): its spline on ``knots`` points.
        t: (M,) times to predict at, in [0, max] with max the collocation's end.
        steps: optimisation steps (default 100; 0 only evaluates).
        lr: the learning rate (default 1e-4: the network starts close); for "lbfgs" the
            first trial step of its strong-Wolfe line search, which may extrapolate.
        optimizer: "adam" (default) or "lbfgs" (each step up to 20 iterations, each
            with a line search).
        parameters: names (or name prefixes, as in ``net.named_parameters()``) of the
            parameters to refine, e.g. ``["branch.linears.3"]`` for a DeepONet's last
            branch layer; ``None`` (default): all.
        q0, p0: the starting state (default rest at q = 0); a network that reads a state
            gets them after the sensors.
        collocation: residual times, uniform on [0, max(t, 2)] (default 200).
        knots: samples of a potential given as a function (default 1,000).
        method: "weights" (default) or "newton".
        tol: ``method="newton"``: the collocation's tolerance (default 1e-10).

    Returns:
        :class:`Refinement`.

    Raises:
        ValueError: for a query-coupled network, a bad count, bad values, or
            ``parameters`` that name no parameter.

    Example:
        >>> import nh_operators as nh
        >>> r = refine(nh.pretrained("deeponet-paper"), nh.PHYSICAL_POTENTIALS["sho"],
        ...            steps=5)
        >>> r.q.shape, r.residual_after < r.residual_before
        ((100,), True)
    """
    if method == "newton":
        from .newton_refinement import refine_newton

        given = {name: value for name, value, default in (
            ("steps", steps, 100), ("lr", lr, 1e-4), ("optimizer", optimizer, "adam"),
            ("collocation", collocation, 200), ("parameters", parameters, None))
            if value != default}
        if given:
            raise ValueError(f"method='newton' refines the trajectory, not the weights: "
                             f"{sorted(given)} do not apply to it")

        return refine_newton(model, potential, t, tol=tol, q0=q0, p0=p0, knots=knots)
    if method != "weights":
        raise ValueError(f"method must be 'weights' or 'newton', got {method!r}")
    start = time.perf_counter()
    net = getattr(model, "net", model)
    if getattr(net, "query_coupled", False):
        raise ValueError("refine needs a network that predicts each time on its own "
                         "(query_coupled False); this one couples its query times")
    if int(steps) != steps or steps < 0 or collocation < 2 or knots < 4:
        raise ValueError(f"steps must be >= 0, collocation >= 2 and knots >= 4; got "
                         f"{steps}, {collocation}, {knots}")
    if optimizer not in ("adam", "lbfgs"):
        raise ValueError(f"optimizer must be 'adam' or 'lbfgs', got {optimizer!r}")
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    if t.size == 0 or not np.all(np.isfinite(t)) or t.min() < 0:
        raise ValueError("t must be finite, non-negative times")
    sensors, grid, values = _potential(potential, knots)
    copy_net = cast_network(copy.deepcopy(net), torch.float64).eval()
    params = _chosen(copy_net, parameters)
    V = torch.tensor(sensors[None])
    if getattr(copy_net, "initial_state", False):
        V = torch.cat([V, torch.tensor([[q0, p0]], dtype=torch.float64)], dim=1)
    spline, potential_values = SensorSpline(grid), torch.tensor(values[None])
    end = max(float(t.max()), float(TIMES[-1]))
    times = torch.tensor(np.linspace(0.0, end, collocation)[:, None]).requires_grad_()
    state = torch.tensor([q0, p0], dtype=torch.float64)

    zero = torch.zeros((1, 1), dtype=torch.float64)

    def residual() -> torch.Tensor:
        # y(0) = state: a shift by the network's own y(0), which keeps dy/dt
        y = copy_net((V, times)) - copy_net((V, zero)) + state
        dy = time_derivative(y, times)
        dV = spline(potential_values, y[..., 0])[1]
        return 0.5 * (torch.mean((dy[..., 0] - y[..., 1]) ** 2)
                      + torch.mean((dy[..., 1] + dV) ** 2))

    before = float(residual().detach())
    opt = (torch.optim.Adam(params, lr=lr) if optimizer == "adam"
           else torch.optim.LBFGS(params, lr=lr, max_iter=20, line_search_fn="strong_wolfe"))

    def closure() -> torch.Tensor:
        opt.zero_grad()
        loss = residual()
        loss.backward()
        return loss

    for _ in range(int(steps)):
        opt.step(closure)
    after = float(residual().detach())
    with torch.no_grad():
        asked = torch.tensor(np.concatenate([[0.0], t])[:, None])
        y = copy_net((V, asked))[0]
        y = (y[1:] - y[:1] + state).numpy()
    return Refinement(y[:, 0].copy(), y[:, 1].copy(), before, after, int(steps),
                      time.perf_counter() - start, copy_net)


def _chosen(net: torch.nn.Module, names: Sequence[str] | None) -> list[torch.nn.Parameter]:
    """The parameters to refine (requires_grad on), the others frozen."""
    if isinstance(names, str):
        names = [names]
    chosen = []
    for name, parameter in net.named_parameters():
        pick = names is None or any(name == n or name.startswith(n + ".") for n in names)
        parameter.requires_grad_(pick)
        if pick:
            chosen.append(parameter)
    if not chosen:
        top = sorted({name.split(".")[0] for name, _ in net.named_parameters()})
        raise ValueError(f"parameters {list(names or [])} name none of the network's "
                         f"parameters (they start with {top})")
    return chosen


def _potential(potential: Any, knots: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sensor values (100,), spline knots, values at the knots) of what was given."""
    if callable(getattr(potential, "V", None)):
        grid = np.linspace(0.0, 1.0, knots)
        values = np.asarray(potential.V(grid), dtype=np.float64).reshape(-1)
        sensors = np.asarray(potential.V(SENSORS), dtype=np.float64).reshape(-1)
    else:
        sensors = np.asarray(potential, dtype=np.float64).reshape(-1)
        grid, values = SENSORS, sensors
    if sensors.shape != SENSORS.shape or values.shape != grid.shape:
        raise ValueError(f"potential must be one potential: {SENSORS.size} sensor values or "
                         f"an object with V(q); got {sensors.size} sensor values")
    if not (np.all(np.isfinite(sensors)) and np.all(np.isfinite(values))):
        raise ValueError("the potential's values must be finite")
    return sensors, grid, values
