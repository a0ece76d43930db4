"""FNO: neuraloperator's 1-D Fourier neural operator as a DeepXDE network (a baseline)."""

import torch

from ._layers import OperatorNet

__all__ = ["FNO"]


class FNO(OperatorNet):
    """neuraloperator's ``FNO`` wrapped for DeepXDE's ``(V, t)`` input (an extra baseline).

    The FNO maps the sensor values, one channel on m grid points, to n_outputs
    channels on ``n_grid`` points of a uniform time grid on [0, ``t_max``]
    (neuraloperator resamples its output to that length). The query times are then
    read off that grid by linear interpolation, so any times in [0, t_max] work; on
    the standard grid (n_grid = 100, t_max = 2) the interpolation is the identity.
    Times outside [0, t_max] raise.

    ``neuralop`` is imported when the first FNO is built (its import takes seconds).

    Args:
        n_modes: Fourier modes kept (default 16; at most n_grid // 2 + 1).
        hidden_channels: width of the Fourier layers (default 64).
        n_layers: Fourier layers (default 4).
        n_grid: points of the internal time grid (default 100).
        t_max: end of the time grid (default 2).
        n_sensors: length m of V (default 100).
        n_outputs: outputs per time (2: q and p; 1 gives shape (B, M)).
        initial_state: True: V carries (q0, p0) after the sensors, (B, m + 2), read as
            two constant input channels beside V (default False: rest at q = 0).

    Example:
        >>> import torch
        >>> net = FNO(n_modes=8, hidden_channels=8, n_layers=2)
        >>> net((torch.zeros(3, 100), torch.linspace(0, 2, 9)[:, None])).shape
        torch.Size([3, 9, 2])
    """

    def __init__(self, n_modes=16, hidden_channels=64, n_layers=4, n_grid=100,
                 t_max=2.0, n_sensors=100, n_outputs=2, initial_state=False):
        super().__init__()
        self.initial_state = bool(initial_state)
        from neuralop.models import FNO as _NeuralopFNO

        self.n_sensors = n_sensors
        self.n_outputs = n_outputs
        self.n_grid = n_grid
        self.t_max = float(t_max)
        self.fno = _NeuralopFNO(n_modes=(n_modes,), in_channels=3 if self.initial_state else 1,
                                out_channels=n_outputs,
                                hidden_channels=hidden_channels, n_layers=n_layers)

    def state_dict(self, *args, **kwargs):
        # neuralop's model adds its constructor arguments under a bare "_metadata"
        # key, which no strict load accepts; the run config rebuilds the model instead.
        state = super().state_dict(*args, **kwargs)
        state.pop("_metadata", None)
        return state

    def _forward(self, V, t):
        V, state = self._sensors_and_state(V)
        x = V[:, None, :]
        if state is not None:
            x = torch.cat([x, state[:, :, None].expand(-1, -1, V.shape[1])], dim=1)
        y = self.fno(x, output_shape=(self.n_grid,))  # (B, n_out, n_grid)
        s = t[:, 0] / self.t_max * (self.n_grid - 1)
        if torch.any(s < -1e-6) or torch.any(s > self.n_grid - 1 + 1e-6):
            raise ValueError(f"FNO query times must lie in [0, {self.t_max}]")
        s = s.clamp(0, self.n_grid - 1)
        lo = s.floor().long().clamp(max=self.n_grid - 2)
        w = (s - lo).to(y.dtype)
        y = y[:, :, lo] * (1 - w) + y[:, :, lo + 1] * w
        return y.transpose(1, 2)
