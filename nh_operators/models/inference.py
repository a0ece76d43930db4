"""Batched prediction with a trained network."""

from typing import Any

import numpy as np
import torch
from numpy.typing import ArrayLike

from .._backend import torch_threads
from .._constants import TIMES
from .._sensors import sensor_values

__all__ = ["as_network", "batched_forward", "interpolate_grid", "predict"]


def batched_forward(net, V, t, batch_size):
    """Yield ``(start, output)`` for consecutive batches of V, in eval mode, without a graph.

    The one place that runs a network over many potentials: inputs are moved to the
    network's device and dtype, ``net.eval()`` holds for the pass and the previous
    mode is restored afterwards, and everything runs under ``torch.no_grad()``. A NumPy
    batch reaches the network as a tensor of its own (converted, or else copied). On the
    CPU, a network with a ``cpu_torch_threads`` count (a light
    :class:`~.phaseonet.PhaseONet`) runs torch on that many threads for the pass.

    Args:
        net: a network taking ``(V, t)``.
        V: array or tensor (N, m).
        t: array or tensor (M, 1).
        batch_size: potentials per forward.

    Yields:
        (start index, output tensor of the batch V[start:start + batch_size]).
    """
    param = next(net.parameters())
    # a network whose torch work per row is light says so: on the CPU its pass then runs
    # torch on that many threads (numba's, which its compiled parts use, stay as set)
    threads = getattr(net, "cpu_torch_threads", None) if param.device.type == "cpu" else None
    if isinstance(t, np.ndarray) and not t.flags.writeable:
        t = t.copy()  # torch warns on read-only arrays (nh.TIMES is one)
    t = torch.as_tensor(t, dtype=param.dtype, device=param.device)
    was_training = net.training
    # switching modes walks every submodule (about 0.1 ms for a small network, a fifth of
    # a single solve): skip it when every module is in eval mode already
    switch = any(m.training for m in net.modules())
    if switch:
        net.eval()
    try:
        with torch.no_grad(), torch_threads(threads):
            for start in range(0, len(V), batch_size):
                rows = V[start:start + batch_size]
                v = torch.as_tensor(rows, dtype=param.dtype, device=param.device)
                if isinstance(rows, np.ndarray) and v.data_ptr() == rows.ctypes.data:
                    v = v.clone()  # no network gets the caller's memory to write on
                yield start, net((v, t))
    finally:
        if switch:
            net.train(was_training)


def as_network(net):
    """The ``torch.nn.Module`` behind what a user passes as a network.

    Args:
        net: a network, or an object holding one in ``.net`` (a
            :class:`~nh_operators.NeuralMethod`, e.g. from :func:`nh_operators.pretrained`).

    Returns:
        torch.nn.Module.

    Raises:
        TypeError: for anything else, saying what to pass instead (for example the
            ``(net, config)`` pair of :func:`~nh_operators.load_model`).

    Example:
        >>> import nh_operators as nh
        >>> model = nh.pretrained("deeponet")
        >>> as_network(model) is model.net
        True
    """
    if isinstance(net, torch.nn.Module):
        return net
    inner = getattr(net, "net", None)
    if isinstance(inner, torch.nn.Module):
        return inner
    if isinstance(net, tuple) and net and isinstance(net[0], torch.nn.Module):
        raise TypeError("got a tuple (net, ...): load_model and train return a pair; unpack "
                        "it first, e.g. net, config = nh.load_model(run_dir)")
    raise TypeError(f"expected a network (torch.nn.Module) or an object holding one in "
                    f".net such as nh.pretrained(name); got {type(net).__name__}")


def _is_training_grid(t: np.ndarray) -> bool:
    # |t − TIMES| ≤ 1e-12 everywhere (np.allclose's test with rtol 0, at a tenth of its
    # cost: t is finite here)
    return t.shape == TIMES.shape and bool((np.abs(t - TIMES) <= 1e-12).all())


#: How far beyond [TIMES[0], TIMES[-1]] an asked time may lie (rounding) and be clamped.
_GRID_SLACK = 1e-12


def _check_in_grid_range(t: np.ndarray, who: str) -> None:
    lo, hi = float(TIMES[0]), float(TIMES[-1])
    if t.min() < lo - _GRID_SLACK or t.max() > hi + _GRID_SLACK:
        raise ValueError(f"{who}: times must lie in the grid's range [{lo:g}, {hi:g}], got "
                         f"t from {t.min():g} to {t.max():g}")


def interpolate_grid(values: np.ndarray, t: np.ndarray, axis: int = -1) -> np.ndarray:
    """Values on the grid :data:`~nh_operators.TIMES` carried to the times ``t``.

    The not-a-knot cubic spline through the grid values, in float64, evaluated at each
    asked time on its own: the value at a time does not depend on the other times.

    Args:
        values: array whose ``axis`` has length 100 (one value per grid time), e.g.
            (N, 100, 2) predictions.
        t: (M,) times in [0, 2] (rounding beyond the ends by up to 1e-12 is clamped).
        axis: the time axis of ``values``.

    Returns:
        float64 array of ``values``' shape with that axis of length M.

    Raises:
        ValueError: if ``values`` has no axis of 100 grid times, or a time lies outside
            the grid's range [0, 2].

    Example:
        >>> import numpy as np
        >>> from nh_operators import TIMES
        >>> y = np.stack([TIMES**3, np.sin(TIMES)])                  # (2, 100)
        >>> out = interpolate_grid(y, np.array([0.5, 1.234]))
        >>> bool(np.allclose(out[0], [0.125, 1.234**3], rtol=0, atol=1e-12))
        True
    """
    values = np.asarray(values, dtype=np.float64)
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    if values.ndim == 0 or values.shape[axis] != TIMES.size:
        raise ValueError(f"values must have {TIMES.size} grid times along axis {axis}, got "
                         f"shape {values.shape}")
    if t.size:
        _check_in_grid_range(t, "interpolation from the grid nh_operators.TIMES")
    from scipy.interpolate import CubicSpline  # a slow import: only for coupled networks

    spline = CubicSpline(TIMES, values, axis=axis, bc_type="not-a-knot")
    return spline(np.clip(t, TIMES[0], TIMES[-1]))


def predict(net: Any, V: Any, t: ArrayLike, batch_size: int = 1000
            ) -> tuple[np.ndarray, np.ndarray]:
    """Predict q(t) and p(t) for many potentials, in batches, without a graph.

    A network whose answer at one time depends on the other times asked
    (``net.query_coupled``: the paper's TraONet and MambONet decoders, VaRONet with
    ``grid_decoder=False``) was trained on the 100-point grid :data:`~nh_operators.TIMES`
    only. It is therefore always run on that grid, and its prediction is carried to the
    asked times by the not-a-knot cubic spline through the grid values (in float64, as
    :func:`~nh_operators.solve` does, :func:`interpolate_grid`): the answer at a time
    does not depend on which other times were asked, and on the grid itself it is the
    network's output unchanged. Other networks are evaluated at ``t`` directly.

    Args:
        net: a network of :data:`nh_operators.MODELS` (or any DeepXDE network with
            the same ``(V, t)`` → (B, M, 2) contract), or an object holding one in
            ``.net``, such as :func:`nh_operators.pretrained` returns.
        V: potentials at the sensors, array of shape (N, 100) (or (100,) for one), or a
            potential object with ``V(q)`` (a batched BoundedPotential gives N rows).
        t: query times, shape (M,) or (M, 1).
        batch_size: potentials per forward (memory grows with it).

    Returns:
        (q, p): NumPy float64 arrays of shape (N, M) (or (M,) for a single V).

    Raises:
        ValueError: for wrong shapes, non-finite inputs or a bad batch size, and for
            times outside [0, 2] (the training grid's range) on a query-coupled network.
        TypeError: if ``net`` is not a network (see :func:`as_network`) or V is not
            real numbers.

    Example:
        >>> import numpy as np, nh_operators as nh
        >>> net = nh.build_model("deeponet", preset="cpu")
        >>> q, p = nh.predict(net, np.zeros((3, 100)), np.linspace(0, 2, 5))
        >>> q.shape
        (3, 5)
        >>> coupled = nh.build_model("traonet", preset="cpu")        # query_coupled
        >>> V = 2 - 8 * nh.SENSORS * (1 - nh.SENSORS)
        >>> alone, _ = nh.predict(coupled, V, [0.7])
        >>> among, _ = nh.predict(coupled, V, [0.1, 0.7, 1.9])
        >>> bool(alone[0] == among[1])
        True
    """
    net = as_network(net)
    if not (type(V) is np.ndarray and V.dtype == np.float64 and V.flags.writeable):
        V = sensor_values(V)  # a copy; a writeable float64 array is read as it is
    single = V.ndim == 1
    if single:
        V = V[None]
    grid = t is TIMES  # the training grid itself: finite, and on the grid
    t = np.array(t, dtype=np.float64)
    if t.ndim == 2 and t.shape[1] == 1:
        t = t[:, 0]
    if V.ndim != 2:
        raise ValueError(f"V must have shape (N, n_sensors), got {V.shape}")
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"t must have shape (M,) or (M, 1) with M ≥ 1, got {t.shape}")
    if not (np.all(np.isfinite(V)) and (grid or np.all(np.isfinite(t)))):
        raise ValueError("V and t must be finite")
    if int(batch_size) != batch_size or batch_size < 1:
        raise ValueError(f"batch_size must be a positive integer, got {batch_size}")
    on_grid = grid or _is_training_grid(t)
    coupled = bool(getattr(net, "query_coupled", False))
    if coupled and not on_grid:
        _check_in_grid_range(t, f"{type(net).__name__} couples its query times, so it is run "
                                "on its training grid nh_operators.TIMES and interpolated")
    asked = t if on_grid or not coupled else TIMES.copy()  # TIMES is read-only
    out = None
    for start, y in batched_forward(net, V, asked[:, None], batch_size):
        y = y.double().cpu().numpy()
        if out is None and len(y) == len(V):  # one forward: its float64 array is the answer
            out = y
            continue
        if out is None:
            out = np.empty((len(V), len(asked), 2))
        out[start:start + len(y)] = y
    if out is None:  # no rows
        out = np.empty((0, len(asked), 2))
    if asked is not t:
        out = interpolate_grid(out, t, axis=1)
    q, p = out[..., 0], out[..., 1]
    return (q[0], p[0]) if single else (q, p)
