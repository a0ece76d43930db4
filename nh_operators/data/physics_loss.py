"""Physics-informed losses for the paper's problem: Hamilton's equations as the target.

What: :class:`PhysicsTerms`, the strategy an :class:`~nh_operators.OperatorData` (or a
training run's data) uses instead of the plain data loss. Its loss columns are the mean
squared residuals of dq/dt = p and dp/dt = −V'(q) at the collocation times, an optional
energy term and an optional label term on a chosen share of the training rows.

The math: V' comes from the not-a-knot cubic spline of the sensors
(:class:`~nh_operators.data.physics_terms.SensorSpline`); the energy term is the mean
squared drift (p²/2 + V(q) − E0)² with E0 = p0²/2 + V(q0). The starting state is not a
loss term: the network's output transform makes it exact
(:func:`~nh_operators.data.physics_terms.state_transform`). With ``causal`` ε > 0 the
residual at time t_k is weighted by exp(−ε Σ_{j<k} r_j² Δt_j) per row (weights not
differentiated), so later times count once earlier ones are resolved (Wang, Sankaran
and Perdikaris, "Respecting causality is all you need for training physics-informed
neural networks", 2022). With ``curriculum`` = K > 0 iterations, only the times up to a
horizon T(i) = t_max·(1/8 + 7/8·min(i/K, 1)) count at iteration i: the fit starts on the
first eighth of the interval and widens to all of it over K iterations.

With ``form="integral"`` the residuals are those of the integral (Picard) form instead,
q(t) − q0 − ∫₀ᵗ p and p(t) − p0 − ∫₀ᵗ F(q) with F = −V', by the trapezoid rule over the
sorted collocation times: no time derivative of the network is taken, so the network
need not be pointwise, an iteration costs about a data-driven one, and a network that
fits labels has a small integral residual too (its autograd derivative can be far off:
residual 8–35 for data-driven DeepONets here), so labels and residual pull the same way.
The trapezoid rule's own error on an exact trajectory is O(Δt²) (about 1e-7 to 1e-5 in
these units on the 100 grid times).

Why: a residual needs no reference solve, so a network can train on potentials without
labels, or with a few (``label_fraction``), and can be refined on one potential at test
time.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import torch

from .._constants import SENSORS
from .physics_terms import SensorSpline, time_derivative

__all__ = ["FORMS", "PhysicsTerms", "integral_residuals"]

#: Names of the loss columns :meth:`PhysicsTerms.losses` returns, in order.
COLUMNS = ("residual q", "residual p", "energy", "labels")

#: The residual forms :class:`PhysicsTerms` takes.
FORMS = ("derivative", "integral")


@dataclasses.dataclass(frozen=True)
class PhysicsTerms:
    """What a physics-informed training run minimises, and on which times and rows.

    Args:
        residual: weight of the two residual columns (default 1).
        energy: weight of the energy-drift column (default 0: off).
        labels: weight of the label column (default 1; it counts only on labelled rows).
        label_fraction: share of the training rows whose labels are used, in [0, 1]
            (default 0: no labels at all; 1: every row, i.e. data-driven plus residual).
        extra_times: random collocation times in [0, t_max] drawn per iteration and
            added to the data's own query times (default 0: the grid only).
        causal: ε of the causal weighting (default 0: every time counts the same).
        t_max: end of the time interval of the extra collocation times, and the horizon
            the curriculum widens to (default 2).
        curriculum: iterations over which the residual's horizon widens from t_max/8 to
            t_max (default 0: the whole interval from the start).
        seed: seed of the labelled rows and the extra times.
        form: ``"derivative"`` (default: dq/dt − p and dp/dt + V'(q), by autograd; the
            network must be pointwise in time) or ``"integral"`` (the Picard form above).

    Raises:
        ValueError: for a negative weight, a fraction outside [0, 1], a negative count
            or ε, a non-positive t_max, or an unknown form.

    Example:
        >>> terms = PhysicsTerms(label_fraction=0.25, seed=1)
        >>> int(terms.labelled(8).sum())
        2
    """

    residual: float = 1.0
    energy: float = 0.0
    labels: float = 1.0
    label_fraction: float = 0.0
    extra_times: int = 0
    causal: float = 0.0
    t_max: float = 2.0
    curriculum: int = 0
    seed: int = 0
    form: str = "derivative"

    def __post_init__(self) -> None:
        if self.form not in FORMS:
            raise ValueError(f"form must be one of {FORMS}, got {self.form!r}")
        for name in ("residual", "energy", "labels", "causal"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be non-negative, got {getattr(self, name)}")
        if not 0.0 <= self.label_fraction <= 1.0:
            raise ValueError(f"label_fraction must lie in [0, 1], got {self.label_fraction}")
        if int(self.extra_times) != self.extra_times or self.extra_times < 0:
            raise ValueError(f"extra_times must be a non-negative integer, got "
                             f"{self.extra_times}")
        if int(self.curriculum) != self.curriculum or self.curriculum < 0:
            raise ValueError(f"curriculum must be a non-negative integer, got "
                             f"{self.curriculum}")
        if not self.t_max > 0:
            raise ValueError(f"t_max must be positive, got {self.t_max}")

    def labelled(self, n_train: int) -> np.ndarray:
        """(n_train,) bool: which training rows (by position) keep their labels."""
        k = int(round(self.label_fraction * n_train))
        mask = np.zeros(n_train, dtype=bool)
        mask[np.random.default_rng([self.seed, 1]).permutation(n_train)[:k]] = True
        return mask

    def times(self, grid: np.ndarray, iteration: int) -> np.ndarray:
        """The collocation times of one iteration: the grid (M, 1), then the extra ones."""
        if not self.extra_times:
            return grid
        rng = np.random.default_rng([self.seed, 2, iteration])
        extra = rng.uniform(0.0, self.t_max, (self.extra_times, 1)).astype(grid.dtype)
        return np.concatenate([grid, extra])

    def losses(self, inputs: tuple[torch.Tensor, torch.Tensor], outputs: torch.Tensor,
               targets: torch.Tensor | None, n_sensors: int = SENSORS.size,
               iteration: int | None = None) -> list[torch.Tensor]:
        """The four weighted loss columns (:data:`COLUMNS`) of one batch.

        Args:
            inputs: DeepXDE's ``(V, t)``: V (B, m) or (B, m + 2) with (q0, p0) last; t
                (M', 1), requiring grad.
            outputs: (B, M', 2) predictions (q, p) of a pointwise network, computed from
                t, with the starting state built in.
            targets: (B, M, 2) labels at the first M times, NaN on unlabelled rows, or
                None.
            n_sensors: m.
            iteration: the training iteration (for the curriculum; None: the whole
                interval).

        Returns:
            [residual q, residual p, energy, labels], each a scalar tensor.

        Raises:
            ValueError: for outputs that are not (B, M', 2).
        """
        V, t = inputs
        if outputs.ndim != 3 or outputs.shape[-1] != 2:
            raise ValueError(f"physics-informed training needs outputs (B, M, 2) = (q, p), "
                             f"got {tuple(outputs.shape)}")
        if not (self.residual or self.energy):  # labels only: skip the derivatives
            zero = outputs.sum() * 0.0
            return [zero, zero, zero, self.labels * self._label_loss(outputs, targets)]
        q, p = outputs[..., 0], outputs[..., 1]
        sensors = V[:, :n_sensors].to(outputs.dtype)
        spline = _spline(n_sensors)
        Vq, dVq = spline(sensors, q)
        if V.shape[1] >= n_sensors + 2:
            q0, p0 = V[:, n_sensors:n_sensors + 1], V[:, n_sensors + 1:n_sensors + 2]
        else:
            q0 = p0 = torch.zeros_like(sensors[:, :1])
        q0, p0 = q0.to(outputs.dtype), p0.to(outputs.dtype)
        V0, dV0 = spline(sensors, q0)
        if self.form == "integral":
            rq, rp = integral_residuals(q, p, -dVq, (q0, p0, -dV0), t)
        else:
            dy = time_derivative(outputs, t)
            rq, rp = dy[..., 0] - p, dy[..., 1] + dVq
        weight = self._causal_weights(rq.detach() ** 2 + rp.detach() ** 2, t)
        if self.curriculum and iteration is not None:
            weight = weight * (t.detach()[:, 0] <= self.horizon(iteration)).to(t.dtype)
        columns = [self.residual * torch.mean(weight * rq**2),
                   self.residual * torch.mean(weight * rp**2)]
        E0 = V0 + p0**2 / 2
        drift = p**2 / 2 + Vq - E0
        columns.append(self.energy * torch.mean(drift**2))
        columns.append(self.labels * self._label_loss(outputs, targets))
        return columns

    def horizon(self, iteration: int) -> float:
        """The end of the times the residual counts at ``iteration`` (the curriculum).

        Example:
            >>> PhysicsTerms(curriculum=100).horizon(50)
            1.125
        """
        if not self.curriculum:
            return self.t_max
        return self.t_max * (0.125 + 0.875 * min(iteration / self.curriculum, 1.0))

    def _causal_weights(self, r2: torch.Tensor, t: torch.Tensor) -> torch.Tensor | float:
        if not self.causal:
            return 1.0
        order = torch.argsort(t.detach()[:, 0])
        ts = t.detach()[order, 0]
        dt = torch.diff(ts, prepend=ts[:1])
        cumulative = torch.cumsum(r2[:, order] * dt, dim=1) - r2[:, order] * dt
        weight = torch.empty_like(r2)
        weight[:, order] = torch.exp(-self.causal * cumulative)
        return weight

    @staticmethod
    def _label_loss(outputs: torch.Tensor, targets: torch.Tensor | None) -> torch.Tensor:
        if targets is None or targets.numel() == 0:
            return outputs.sum() * 0.0
        rows = torch.isfinite(targets.reshape(len(targets), -1)).all(dim=1)
        if not bool(rows.any()):
            return outputs.sum() * 0.0
        m = targets.shape[1]
        err = outputs[rows, :m] - targets[rows].to(outputs.dtype)
        return torch.mean(err**2)


def integral_residuals(q: torch.Tensor, p: torch.Tensor, F: torch.Tensor,
                       start: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
                       t: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The residuals of Hamilton's equations in integral (Picard) form, by the trapezoid
    rule from t = 0 over the sorted times.

    Args:
        q, p: (B, M) positions and momenta at the times ``t``.
        F: (B, M) the force −V'(q) at q.
        start: (q0, p0, F0), each (B, 1): the starting state and its force, at t = 0.
        t: (M, 1) times ≥ 0, any order (repeats allowed).

    Returns:
        (r_q, r_p), each (B, M) in the order of ``t``: q(t) − q0 − ∫₀ᵗ p and
        p(t) − p0 − ∫₀ᵗ F.

    Example:
        >>> t = torch.linspace(0, 1, 201, dtype=torch.float64)[:, None]
        >>> q, p = torch.sin(t.T), torch.cos(t.T)      # the oscillator V = q²/2
        >>> one = torch.ones(1, 1, dtype=torch.float64)
        >>> rq, rp = integral_residuals(q, p, -q, (0 * one, one, 0 * one), t)
        >>> bool(rq.abs().max() < 1e-5 and rp.abs().max() < 1e-5)
        True
    """
    q0, p0, F0 = start
    ts = t.detach()[:, 0]
    order = torch.argsort(ts)
    dt = torch.diff(ts[order], prepend=ts.new_zeros(1))
    qs, ps, Fs = q[:, order], p[:, order], F[:, order]
    Q = q0 + torch.cumsum(0.5 * (torch.cat([p0, ps[:, :-1]], 1) + ps) * dt, 1)
    P = p0 + torch.cumsum(0.5 * (torch.cat([F0, Fs[:, :-1]], 1) + Fs) * dt, 1)
    rq, rp = torch.empty_like(q), torch.empty_like(p)
    rq[:, order], rp[:, order] = qs - Q, ps - P
    return rq, rp


@functools.lru_cache(maxsize=8)
def _spline(n_sensors: int) -> SensorSpline:
    """The sensors' spline operator for m uniform sensors on [0, 1] (built once per m)."""
    return SensorSpline(np.linspace(0.0, 1.0, n_sensors))
