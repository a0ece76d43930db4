"""The shared head of PhaseONet's networks: an MLP's coefficients in a trainable basis on a
uniform grid, read off by linear interpolation.

The MLP's last layer gives ``basis`` coefficients per output; a trainable basis turns
them into values on ``grid`` uniform nodes, added to a start table (the output's shift);
an asked point is read off between its two nodes by two gathers and a lerp (few, cheap
tensor operations, which is what a CPU pays for at batch 1,000). For an orbit the grid
is the half-phase h ∈ [0, 1/2], h = 1/2 − |u − 1/2| at the phase u = (t / T) mod 1, and p
changes sign at u = 1/2 (:meth:`BasisHeadNet.read_half_phase`).
"""

from collections.abc import Sequence
from typing import Any

import numpy as np
import torch

from ._layers import OperatorNet
from .phase_readout import read_orbit_rows

__all__ = ["ACTIVATIONS", "BasisHeadNet", "check_one_dimensional", "grid_lerp", "half_phase",
           "orbit_harmonics"]

Tensor = torch.Tensor

#: Activation name → module class of the branch MLP.
ACTIVATIONS: dict[str, type[torch.nn.Module]] = {
    "gelu": torch.nn.GELU, "relu": torch.nn.ReLU, "tanh": torch.nn.Tanh,
    "silu": torch.nn.SiLU}


def check_one_dimensional(name: str, query_dim: int, n_outputs: int,
                          outputs: tuple[int, ...], query_coupled: bool = False) -> None:
    """Refuse a problem other than the 1-D Hamiltonian orbit, naming what to use instead.

    Args:
        name: the network's name, for the message.
        query_dim: the asked query dimension d.
        n_outputs: the asked number of outputs k.
        outputs: the k the network serves.
        query_coupled: the asked coupling of the query points (must be False: each time
            is answered on its own).

    Raises:
        ValueError: for d ≠ 1, k not in ``outputs`` or a coupling asked.

    Example:
        >>> check_one_dimensional("PhaseONet", 1, 2, (1, 2))
    """
    instead = ("for other operator problems use a general network, e.g. "
               "build_model('deeponet', n_outputs=k, query_dim=d) or 'fno'")
    if query_dim != 1:
        raise ValueError(f"{name} serves only the 1-D Hamiltonian problem: its query "
                         f"points are times (query_dim=1), got query_dim={query_dim}; "
                         f"{instead}")
    if n_outputs not in outputs:
        what = " or ".join(str(k) for k in outputs)
        raise ValueError(f"{name} serves only the 1-D Hamiltonian problem: n_outputs must "
                         f"be {what} (q and p{', or q alone' if 1 in outputs else ''}), got "
                         f"n_outputs={n_outputs}; {instead}")
    if query_coupled:
        raise ValueError(f"{name} answers each time on its own: query_coupled must be "
                         f"False, got {query_coupled!r}")


def orbit_harmonics(basis: int, grid: int, moving: bool) -> tuple[np.ndarray, np.ndarray]:
    """The half-orbit's basis at construction and its harmonic start, on h ∈ [0, 1/2].

    Args:
        basis: functions per output.
        grid: nodes of h.
        moving: whether P starts at the harmonic orbit's π sin 2πh (from a state) or at 0
            (at rest).

    Returns:
        (harmonics (2, basis, grid): cos 2πmh for q and sin 2π(m+1)h for p, m < basis;
        start (2, grid): (1 − cos 2πh)/2, and π sin 2πh or 0), float64.

    Example:
        >>> harmonics, start = orbit_harmonics(2, 3, moving=False)
        >>> harmonics.shape, start[0].round(12).tolist()
        ((2, 2, 3), [0.0, 0.5, 1.0])
    """
    h = np.linspace(0.0, 0.5, grid)
    angle = 2 * np.pi * h
    m = np.arange(basis)[:, None]
    harmonics = np.stack([np.cos(m * angle), np.sin((m + 1) * angle)])
    speed = np.pi * np.sin(angle) if moving else np.zeros(grid)
    return harmonics, np.stack([(1 - np.cos(angle)) / 2, speed])


def grid_lerp(tables: Sequence[Tensor], x: Tensor) -> list[Tensor]:
    """Each table read at fractional grid coordinates by linear interpolation.

    Args:
        tables: each (B, grid), grid ≥ 2.
        x: (B, M) grid coordinates in [0, grid − 1] (clamped to the end cells).

    Returns:
        one (B, M) tensor per table.

    Example:
        >>> grid_lerp([torch.tensor([[0.0, 10.0, 20.0]])], torch.tensor([[0.5, 1.75]]))
        [tensor([[ 5.0000, 17.5000]])]
    """
    grid = tables[0].shape[1]
    j = torch.floor(x).clamp_(0, grid - 2)
    weight = (x - j).clamp_(max=1)
    left = j.long()
    right = left + 1
    return [torch.lerp(torch.gather(g, 1, left), torch.gather(g, 1, right), weight)
            for g in tables]


def half_phase(u: Tensor, grid: int, dtype: torch.dtype) -> tuple[Tensor, Tensor]:
    """The grid coordinate of the half-phase, and the sign of p, at phases u.

    Args:
        u: (B, M) phases t / T (+ u0), any real value (taken mod 1), modified in place.
        grid: nodes of the half-phase grid on h ∈ [0, 1/2].
        dtype: the dtype of the results.

    Returns:
        (x, sign), each (B, M): x = 2 (grid − 1) h with h = 1/2 − abs(u mod 1 − 1/2), and
        sign +1 while u mod 1 < 1/2, −1 after (0 exactly at 1/2).

    Example:
        >>> half_phase(torch.tensor([[0.25, 1.75]]), 3, torch.float32)
        (tensor([[1., 1.]]), tensor([[ 1., -1.]]))
    """
    d = torch.frac(u).sub_(0.5)                       # u − 1/2 ∈ [−1/2, 1/2)
    sign = torch.sign(d).neg_().to(dtype)             # p changes sign at T/2
    x = d.abs_().mul_(-2 * (grid - 1)).add_(grid - 1).to(dtype)
    return x, sign


class BasisHeadNet(OperatorNet):
    """Abstract: a branch MLP whose coefficients, in a trainable basis on a uniform grid,
    give one table per output, added to a start table.

    Subclasses build the basis and the start for their grid, feed the MLP, and read the
    tables (:meth:`shape_tables`, :meth:`read_half_phase` or :func:`grid_lerp`) in their
    ``_forward``. The ``state_dict`` holds ``basis`` and ``branch.*`` only.

    Args:
        d_in: the MLP's input width.
        harmonics: (k, basis, grid) the basis at construction, one per output.
        start: (k, grid) the outputs' start tables (non-persistent buffers).
        width: hidden width of the MLP (≥ 1).
        depth: hidden layers (≥ 1).
        activation: a key of :data:`ACTIVATIONS`.
        zero_correction: start the MLP's last layer at zero (the start is the answer).
        n_sensors: the sensor count m.
        regularization: DeepXDE's ``NN.regularizer`` (e.g. ``["l2", 1e-5]``), or None.

    Raises:
        ValueError: for grid < 2, a non-positive basis, depth or width, or an unknown
            activation.
    """

    query_coupled = False

    def __init__(self, d_in: int, harmonics: np.ndarray, start: np.ndarray, *, width: int,
                 depth: int, activation: str, zero_correction: bool = False,
                 n_sensors: int = 100, regularization: Any = None) -> None:
        super().__init__()
        k, basis, grid = harmonics.shape
        if grid < 2 or basis < 1 or depth < 1 or width < 1:
            raise ValueError(f"need grid ≥ 2 and positive basis, depth and width; got "
                             f"grid={grid}, basis={basis}, depth={depth}, width={width}")
        if activation not in ACTIVATIONS:
            raise ValueError(f"unknown activation {activation!r}; choose from "
                             f"{sorted(ACTIVATIONS)}")
        self.n_sensors, self.n_outputs, self.grid = n_sensors, k, grid
        self.regularizer = regularization
        self.basis = torch.nn.Parameter(torch.tensor(harmonics, dtype=torch.float32))
        self.register_buffer("out_shift", torch.tensor(start[:, None, :], dtype=torch.float32),
                             persistent=False)
        # the first output's correction scaled by 0.1, so that the first steps do not
        # swamp its start
        self.register_buffer("out_scale", torch.tensor([0.1, 1.0])[:k, None, None],
                             persistent=False)
        layers: list[torch.nn.Module] = []
        d = d_in
        for _ in range(depth):
            layers += [torch.nn.Linear(d, width), ACTIVATIONS[activation]()]
            d = width
        last = torch.nn.Linear(d, k * basis)
        if zero_correction:
            torch.nn.init.zeros_(last.weight)
            torch.nn.init.zeros_(last.bias)
        layers.append(last)
        self.branch = torch.nn.Sequential(*layers)

    def start_tables(self) -> tuple[Tensor, ...]:
        """The start tables built in, one (grid,) per output."""
        return tuple(s[0] for s in self.out_shift)

    def shape_tables(self, coeffs: Tensor, start: Sequence[Tensor]) -> list[Tensor]:
        """Start plus the MLP's correction in the basis, per output.

        Args:
            coeffs: (B, k · basis) the MLP's output.
            start: one (grid,) or (B, grid) table per output.

        Returns:
            one (B, grid) table per output, in the dtype of ``coeffs``.
        """
        r = self.basis.shape[1]
        # per output a plain 2-D product: contiguous operands keep the head cheap on a CPU
        return [torch.addmm(start[k].to(coeffs.dtype), coeffs[:, k * r:(k + 1) * r],
                            self.basis[k] * self.out_scale[k, 0])
                for k in range(self.n_outputs)]

    def read_half_phase(self, tables: Sequence[Tensor], u: Tensor) -> list[Tensor]:
        """The tables of Q (and P) on the half-phase grid read at phases u.

        Args:
            tables: one (B, grid) per output: Q, then abs(p)'s table.
            u: (B, M) phases (mod 1), modified in place.

        Returns:
            one (B, M) tensor per output; the second (p) with its sign.
        """
        x, sign = half_phase(u, self.grid, tables[0].dtype)
        ys = grid_lerp(tables, x)
        if len(ys) == 2:
            ys[1] = ys[1].mul_(sign) if not torch.is_grad_enabled() else ys[1] * sign
        return ys

    def read_orbit(self, tables: Sequence[Tensor], rate: Tensor, t: Tensor,
                   offset: Tensor | None = None) -> Tensor:
        """The tables read at the phases u = rate · t + offset, stacked.

        On the CPU, when no gradient flows through the tables or the rate, one compiled
        loop (:mod:`.phase_readout`, the phase in float64); otherwise
        :meth:`read_half_phase` on u (in float64 when an offset is given or a time
        exceeds 16, else in the tables' dtype, whose 6e-8 relative error then moves the
        phase by less than 1e-6).

        Args:
            tables: one (B, grid) per output: Q, then abs(p)'s table.
            rate: (B,) 1 / T, float64.
            t: (M, 1) times.
            offset: (B,) float64 phase at t = 0, or None (0).

        Returns:
            (B, M, k) in the tables' dtype: q, then p with its sign.
        """
        grad = torch.is_grad_enabled() and (
            rate.requires_grad or any(g.requires_grad for g in tables)
            or (offset is not None and offset.requires_grad))
        if tables[0].device.type == "cpu" and not grad:
            q = tables[0].detach().contiguous().numpy()
            p = tables[-1].detach().contiguous().numpy()
            zero = np.zeros(q.shape[0]) if offset is None else (
                offset.detach().to(torch.float64).numpy())
            times = t[:, 0].detach().to(torch.float64).contiguous().numpy()
            return torch.from_numpy(read_orbit_rows(
                q, p, rate.detach().to(torch.float64).contiguous().numpy(), zero,
                times, len(tables)))
        wide = (torch.float64 if offset is not None or bool((t.abs() > 16).any())
                else tables[0].dtype)
        u = torch.outer(rate.to(wide), t[:, 0].to(wide))
        if offset is not None:
            u = u + offset.to(wide)[:, None]
        return torch.stack(self.read_half_phase(tables, u), dim=-1)
