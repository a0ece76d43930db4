"""FNO: neuraloperator's Fourier neural operator as a DeepXDE network (a baseline)."""

from __future__ import annotations

from collections.abc import Sequence

import torch

from ._layers import OperatorNet, match_default_float
from .readout import GridSpline, as_ranges, tensor_spline

__all__ = ["FNO"]

#: What to install when ``neuralop`` is missing.
INSTALL_HINT = 'pip install "nh-operators[fno]"'


def _neuralop_fno():
    """neuraloperator's FNO class, or an ImportError that says what to install."""
    try:
        from neuralop.models import FNO as NeuralopFNO
    except ImportError as err:
        raise ImportError("nh_operators' FNO needs the neuraloperator package "
                          f"(import neuralop failed: {err}); install it with "
                          f"{INSTALL_HINT}") from err
    return NeuralopFNO


class FNO(OperatorNet):
    """neuraloperator's ``FNO`` wrapped for DeepXDE's ``(V, x)`` input (an extra baseline).

    The FNO maps the sensor values, one channel, to n_outputs channels on a uniform
    grid of ``n_grid`` points per query coordinate spanning ``query_range``
    (neuraloperator resamples its output to that size). The query points are then read
    off that grid by the not-a-knot cubic spline through the grid values
    (:class:`~nh_operators.models.readout.GridSpline`; in d dimensions the tensor
    product of 1-D splines, :func:`~nh_operators.models.readout.tensor_spline`): a
    prediction at a point depends only on that point, and it is twice differentiable
    in every coordinate, so ``dde.grad.jacobian`` and ``dde.grad.hessian`` give the
    pointwise derivatives (``query_coupled`` is always False). Points outside the
    range raise. On the standard grid itself (the points equal to the grid, needing no
    gradient) the grid values are read by the linear interpolation of earlier
    versions, so shipped predictions keep their bits.

    **Query points and their scaling.** Query points are DeepXDE's (M, d) tensor;
    coordinate j must lie in ``query_range[j] = (lo, hi)`` (default (0, t_max) for
    every coordinate), which is mapped onto the FNO's grid index (neuraloperator's own
    grid channels span [0, 1] along each axis). With d = 1 the FNO is 1-D: the m
    sensors on its one axis in, ``n_grid`` points out. With d > 1 the sensors are
    taken as samples of a function of the first coordinate: the input is the sensor
    channel along the first axis (m points), repeated along the d − 1 other axes
    (``n_grid`` points each), a d-D FNO with ``n_modes`` modes per axis maps it to an
    ``n_grid``^d output grid, and the points are read off by the tensor-product
    spline. The cost grows as ``n_grid``^d: for d = 2 an ``n_grid`` of 32 to 64 is a
    good start.

    ``neuralop`` is imported when the first FNO is built (its import takes seconds);
    without it the constructor raises an ImportError naming the extra to install,
    ``pip install "nh-operators[fno]"``.

    Args:
        n_modes: Fourier modes kept per axis (default 16; at most n_grid // 2 + 1).
        hidden_channels: width of the Fourier layers (default 64).
        n_layers: Fourier layers (default 4).
        n_grid: grid points per axis of the output grid (default 100, at least 4).
        t_max: end of the default range (0, t_max) of every coordinate (default 2).
        n_sensors: length m of V (default 100).
        n_outputs: outputs per point (2: q and p; 1 gives shape (B, M)).
        initial_state: True: V carries (q0, p0) after the sensors, (B, m + 2), read as
            two constant input channels beside V (default False: rest at q = 0).
        query_dim: number d of coordinates of a query point (default 1).
        query_range: (lo, hi) of every coordinate, or d pairs (default (0, t_max)).
        query_coupled: only False (or None) is accepted: the read-out is pointwise.
        regularization: DeepXDE's regularizer, e.g. ``["l2", 1e-5]`` (as its own
            networks take it; ``dde.Model.compile`` reads ``net.regularizer``).

    Raises:
        ImportError: without neuraloperator.
        ValueError: for ``query_coupled=True``, a bad range or a bad size.

    The network is built in DeepXDE's default float (``dde.config.set_default_float``;
    the spectral weights then become complex128 for float64).

    References:
        Z. Li et al., "Fourier neural operator for parametric partial differential
        equations", ICLR (2021); J. Kossaifi et al., "A library for learning neural
        operators" (neuraloperator, 2024).

    Example:
        >>> import torch
        >>> net = FNO(n_modes=8, hidden_channels=8, n_layers=2)
        >>> net((torch.zeros(3, 100), torch.linspace(0, 2, 9)[:, None])).shape
        torch.Size([3, 9, 2])
    """

    def __init__(self, n_modes: int = 16, hidden_channels: int = 64, n_layers: int = 4,
                 n_grid: int = 100, t_max: float = 2.0, n_sensors: int = 100,
                 n_outputs: int = 2, initial_state: bool = False, query_dim: int = 1,
                 query_range: Sequence | None = None, query_coupled: bool | None = None,
                 regularization: list | None = None) -> None:
        super().__init__()
        if query_coupled:
            raise ValueError("FNO reads every query point off its grid on its own: "
                             "query_coupled=True is not available (use False)")
        for name, value, least in (("n_sensors", n_sensors, 1), ("n_outputs", n_outputs, 1),
                                   ("query_dim", query_dim, 1), ("n_grid", n_grid, 4)):
            if int(value) < least:
                raise ValueError(f"{name} must be at least {least}, got {value}")
        neuralop_fno = _neuralop_fno()
        self.query_coupled = False
        self.initial_state = bool(initial_state)
        self.n_sensors = int(n_sensors)
        self.n_outputs = int(n_outputs)
        self.n_grid = int(n_grid)
        self.t_max = float(t_max)
        self.query_dim = int(query_dim)
        self.query_range = as_ranges((0.0, self.t_max) if query_range is None else query_range,
                                     self.query_dim)
        self.regularizer = regularization
        self._splines = [GridSpline(lo, hi, self.n_grid) for lo, hi in self.query_range]
        self.fno = neuralop_fno(n_modes=(n_modes,) * self.query_dim,
                                in_channels=3 if self.initial_state else 1,
                                out_channels=self.n_outputs,
                                hidden_channels=hidden_channels, n_layers=n_layers)
        match_default_float(self)

    def state_dict(self, *args, **kwargs):
        # neuralop's model adds its constructor arguments under a bare "_metadata"
        # key, which no strict load accepts; the run config rebuilds the model instead.
        state = super().state_dict(*args, **kwargs)
        state.pop("_metadata", None)
        return state

    def grid_values(self, V: torch.Tensor) -> torch.Tensor:
        """The FNO's outputs on its grid.

        Args:
            V: (B, m) sensors (with ``initial_state``, (B, m + 2)).

        Returns:
            (B, n_outputs, n_grid, ..., n_grid), d grid axes.
        """
        V, state = self._sensors_and_state(V)
        x = V[:, None, :]
        if state is not None:
            x = torch.cat([x, state[:, :, None].expand(-1, -1, V.shape[1])], dim=1)
        extra = (self.n_grid,) * (self.query_dim - 1)
        x = x.reshape(*x.shape, *(1,) * len(extra)).expand(*x.shape, *extra)
        _forget_stale_grid(self.fno, x)
        return self.fno(x, output_shape=(self.n_grid,) * self.query_dim)

    def _forward(self, V: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        y = self.grid_values(V)
        for j, spline in enumerate(self._splines):
            spline.check(t[:, j], "FNO query times" if self.query_dim == 1
                         else f"FNO query coordinate {j}")
        if self.query_dim == 1 and not t.requires_grad:
            nodes = torch.tensor(self._splines[0].nodes, dtype=t.dtype, device=t.device)
            if t.shape[0] == nodes.shape[0] and torch.equal(t[:, 0], nodes):
                return self._linear_on_grid(y, t[:, 0])
        return tensor_spline(self._splines, y, t).transpose(1, 2)

    def _linear_on_grid(self, y: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """The linear interpolation of earlier versions, kept on the grid for its bits."""
        lo_t, hi_t = self.query_range[0]
        s = (t - lo_t) / (hi_t - lo_t) * (self.n_grid - 1)
        s = s.clamp(0, self.n_grid - 1)
        lo = s.floor().long().clamp(max=self.n_grid - 2)
        w = (s - lo).to(y.dtype)
        y = y[:, :, lo] * (1 - w) + y[:, :, lo + 1] * w
        return y.transpose(1, 2)


def _forget_stale_grid(fno: torch.nn.Module, x: torch.Tensor) -> None:
    """Drop neuraloperator's cached positional grid when it is on another device or dtype.

    neuraloperator 2.0's ``GridEmbeddingND`` caches its grid by resolution only, outside
    the module's tensors, so after ``.cuda()`` or ``.double()`` it would hand back the
    grid of the first call (a device or dtype mismatch in ``torch.cat``).
    """
    embedding = getattr(fno, "positional_embedding", None)
    cached = getattr(embedding, "_grid", None)
    if embedding is not None and cached and (cached[0].device != x.device
                                             or cached[0].dtype != x.dtype):
        embedding._grid = None
