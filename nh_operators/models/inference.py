"""Batched prediction with a trained network."""

import warnings

import numpy as np
import torch

from .._constants import TIMES
from .._sensors import sensor_values

__all__ = ["predict", "batched_forward", "as_network"]


def batched_forward(net, V, t, batch_size):
    """Yield ``(start, output)`` for consecutive batches of V, in eval mode, without a graph.

    The one place that runs a network over many potentials: inputs are moved to the
    network's device and dtype, ``net.eval()`` holds for the pass and the previous
    mode is restored afterwards, and everything runs under ``torch.no_grad()``.

    Args:
        net: a network taking ``(V, t)``.
        V: array or tensor (N, m).
        t: array or tensor (M, 1).
        batch_size: potentials per forward.

    Yields:
        (start index, output tensor of the batch V[start:start + batch_size]).
    """
    param = next(net.parameters())
    t = torch.as_tensor(t, dtype=param.dtype, device=param.device)
    was_training = net.training
    # switching modes walks every submodule (about 0.1 ms for a small network, a fifth of
    # a single solve): skip it when every module is in eval mode already
    switch = any(m.training for m in net.modules())
    if switch:
        net.eval()
    try:
        with torch.no_grad():
            for start in range(0, len(V), batch_size):
                v = torch.as_tensor(V[start:start + batch_size], dtype=param.dtype,
                                    device=param.device)
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


def _is_training_grid(t):
    return t.shape == TIMES.shape and np.allclose(t, TIMES, rtol=0, atol=1e-12)


def predict(net, V, t, batch_size=1000):
    """Predict q(t) and p(t) for many potentials, in batches, without a graph.

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
        ValueError: for wrong shapes, non-finite inputs or a bad batch size.
        TypeError: if ``net`` is not a network (see :func:`as_network`) or V is not
            real numbers.

    Warns:
        UserWarning: when a network whose query times are coupled (TraONet, VaRONet,
            MambONet: ``net.query_coupled``) is asked at times other than
            :data:`~nh_operators.TIMES`.

    Example:
        >>> import numpy as np, nh_operators as nh
        >>> net = nh.build_model("deeponet", preset="cpu")
        >>> q, p = nh.predict(net, np.zeros((3, 100)), np.linspace(0, 2, 5))
        >>> q.shape
        (3, 5)
    """
    net = as_network(net)
    V = sensor_values(V)
    single = V.ndim == 1
    if single:
        V = V[None]
    t = np.array(t, dtype=np.float64)
    if t.ndim == 2 and t.shape[1] == 1:
        t = t[:, 0]
    if V.ndim != 2:
        raise ValueError(f"V must have shape (N, n_sensors), got {V.shape}")
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"t must have shape (M,) or (M, 1) with M ≥ 1, got {t.shape}")
    if not (np.all(np.isfinite(V)) and np.all(np.isfinite(t))):
        raise ValueError("V and t must be finite")
    if int(batch_size) != batch_size or batch_size < 1:
        raise ValueError(f"batch_size must be a positive integer, got {batch_size}")
    if getattr(net, "query_coupled", False) and not _is_training_grid(t):
        warnings.warn(
            f"{type(net).__name__} couples the query times: asked at times other than the "
            "100-point training grid, its predictions change (by up to 0.1-1 in q for the "
            "10-epoch cpu models, docs/evaluation.md). Predict on nh_operators.TIMES and "
            "interpolate, or use deeponet or fno, whose predictions do not depend on the "
            "other times asked", UserWarning, stacklevel=2)
    out = np.empty((len(V), len(t), 2))
    for start, y in batched_forward(net, V, t[:, None], batch_size):
        out[start:start + len(y)] = y.double().cpu().numpy()
    q, p = out[..., 0], out[..., 1]
    return (q[0], p[0]) if single else (q, p)
