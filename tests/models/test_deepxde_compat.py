"""Compatibility with DeepXDE itself: its operator-learning example with our TraONet.

DeepXDE's antiderivative example learns G: v ↦ u with u(x) = ∫₀ˣ v, on a
``TripleCartesianProd`` of GRF samples. Here the DeepONet is swapped for our
``traonet`` and trained by a plain ``dde.Model`` (DeepXDE's optimiser by name, its
own batching), with none of our training machinery.
"""

import numpy as np
import pytest
import torch

import nh_operators as nh

from nh_operators._backend import ensure_pytorch_backend  # noqa: E402
dde = ensure_pytorch_backend()


def antiderivative_data(n, seed):
    np.random.seed(seed)  # dde.data.GRF draws from NumPy's global generator
    space = dde.data.GRF(length_scale=0.2)
    x = np.linspace(0, 1, 100)
    v = space.eval_batch(space.random(n), x[:, None])
    dx = np.diff(x)
    u = np.concatenate([np.zeros((n, 1)),
                        np.cumsum(0.5 * (v[:, 1:] + v[:, :-1]) * dx, axis=1)], axis=1)
    return v.astype(np.float32), x[:, None].astype(np.float32), u.astype(np.float32)


def test_traonet_learns_the_antiderivative_in_deepxdes_own_loop():
    v, x, u = antiderivative_data(150, seed=0)
    data = dde.data.TripleCartesianProd((v[:100], x), u[:100], (v[100:], x), u[100:])
    torch.manual_seed(0)
    net = nh.build_model("traonet", "cpu", d_model=16, nhead=2, num_layers=1,
                         dim_feedforward=64, n_outputs=1, time_scale=99.0)
    model = dde.Model(data, net)
    model.compile("adam", lr=3e-3, metrics=["mean l2 relative error"])
    history, state = model.train(iterations=150, batch_size=50, display_every=50,
                                 verbose=0)
    first, last = history.loss_test[0][0], history.loss_test[-1][0]
    assert last < 0.05 * first
    assert state.y_pred_test.shape == u[100:].shape
    # and the trained network answers through DeepXDE's predict as well
    with torch.no_grad():
        y = model.predict((v[100:], x))
    assert np.mean((y - u[100:]) ** 2) == pytest.approx(last, rel=1e-4)
