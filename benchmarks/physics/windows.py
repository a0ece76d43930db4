"""Time-marching without labels: a short-window flow map, composed over [0, 2] (issue 43).

A residual over the whole horizon [0, 2] collapses (``docs/without_labels.md``): the
trajectory oscillates, and an early error is cheap to the residual but fatal to the
answer. The usual remedy is to march in time. Here a DeepONet that reads a starting
state (``initial_state=True``) is trained, without a label, on the residual and
energy terms over a short window [0, w] only. The training rows are
``paper-states-standard`` potentials from random states (``PhysicsTerms(t_max=w,
curriculum=1)``: from the second iteration on, only times ≤ w count, and the 64 extra
collocation times per iteration are drawn in [0, w]). A trajectory on [0, 2] is then
ceil(2 / w) windows, each started from where the last one ended (:func:`composed`).

Used by ``without_labels.py --modes window`` (the training and the table); run on its
own to score a finished run::

    python benchmarks/physics/windows.py RUN_DIR TEST.h5 [--window 0.25]
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

from nh_operators.data import SensorSpline, load_dataset
from nh_operators.training import load_model


def window_physics(window: float, energy: float) -> dict:
    """``TrainConfig.physics`` of the window mode: residual and energy on [0, window]."""
    return {"energy": energy, "t_max": window, "curriculum": 1, "extra_times": 64}


def window_of(t: np.ndarray, window: float) -> tuple[int, np.ndarray]:
    """The number of windows over [0, max t] and the window of each time: a time on a
    boundary belongs to the window it starts, but the last time to the last window."""
    count = max(1, int(np.ceil(t[-1] / window - 1e-12)))
    return count, np.minimum((t / window).astype(int), count - 1)


def composed(net: torch.nn.Module, V: np.ndarray, t: np.ndarray,
             window: float) -> tuple[np.ndarray, np.ndarray]:
    """(q, p), each (N, M) float64: the trajectory from rest at the sorted times ``t``,
    window by window.

    Args:
        net: a network that reads a state: its input is V (N, m) with (q0, p0) appended.
        V: (N, m) sensor values; t: (M,) sorted times ≥ 0; window: the window's length.
    """
    net = net.double().eval()
    Vt = torch.as_tensor(V, dtype=torch.float64)
    n = Vt.shape[0]
    q0 = p0 = torch.zeros(n, 1, dtype=torch.float64)
    count, which = window_of(t, window)
    q, p = np.empty((n, t.size)), np.empty((n, t.size))
    with torch.no_grad():
        for k in range(count):
            idx = np.flatnonzero(which == k)
            tau = np.r_[t[idx] - k * window, window]  # the window's times, then its end
            y = net((torch.cat([Vt, q0, p0], 1), torch.as_tensor(tau[:, None])))
            q[:, idx], p[:, idx] = y[:, :-1, 0].numpy(), y[:, :-1, 1].numpy()
            q0, p0 = y[:, -1:, 0].clone(), y[:, -1:, 1].clone()
    return q, p


def scores(net: torch.nn.Module, path: str, window: float) -> dict[str, float]:
    """Mean and median L_tot and energy drift of the composed trajectories on a test set
    (the residual is not defined across the windows' joints: NaN), and the median L_tot
    of one window started from the true state at its start, per window (``windows``)."""
    data = load_dataset(path)
    q, p = composed(net, data.V, data.t, window)
    loss = 0.5 * (np.mean((q - data.q) ** 2, 1) + np.mean((p - data.p) ** 2, 1))
    value, _ = SensorSpline(data.x)(torch.as_tensor(data.V), torch.as_tensor(q))
    drift = np.mean((0.5 * p**2 + value.numpy() - data.V[:, :1]) ** 2, 1)
    return {"mean": float(loss.mean()), "median": float(np.median(loss)),
            "drift": float(drift.mean()), "residual": float("nan"),
            "windows": one_window_medians(net, data, window)}


def one_window_medians(net: torch.nn.Module, data, window: float) -> list[float]:
    """Per window, the median L_tot of that window alone, started from the labels' state
    at its first asked time: how good one window is, before any composing."""
    t = data.t
    count, which = window_of(t, window)
    Vt = torch.as_tensor(data.V, dtype=torch.float64)
    out = []
    with torch.no_grad():
        for k in range(count):
            idx = np.flatnonzero(which == k)
            s = idx[0]
            state = torch.as_tensor(np.stack([data.q[:, s], data.p[:, s]], 1))
            y = net((torch.cat([Vt, state], 1), torch.as_tensor(t[idx, None] - t[s])))
            err = 0.5 * (np.mean((y[..., 0].numpy() - data.q[:, idx]) ** 2, 1)
                         + np.mean((y[..., 1].numpy() - data.p[:, idx]) ** 2, 1))
            out.append(float(np.median(err)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    parser.add_argument("run", help="a run directory of the window mode")
    parser.add_argument("test", help="a test set (.h5) from rest")
    parser.add_argument("--window", type=float, default=0.25)
    args = parser.parse_args()
    net, _ = load_model(args.run)
    result = scores(net, args.test, args.window)
    print(f"composed: mean L_tot {result['mean']:.3g}, median {result['median']:.3g}, "
          f"drift {result['drift']:.3g}; one window from the true state, median L_tot "
          f"per window: {', '.join(f'{x:.2g}' for x in result['windows'])}")


if __name__ == "__main__":
    main()
