"""Physics-informed training as a mode of nh.train: residual loss, checkpoints, resume."""

import numpy as np
import pytest
import torch

import nh_operators as nh
from nh_operators.data import generate_dataset
from nh_operators.training import load_model


@pytest.fixture(scope="module")
def small():
    return generate_dataset(60, seed=4, progress=False)


def cfg(epochs=3, **physics):
    return nh.TrainConfig("deeponet", preset="cpu", arch=dict(hidden_size=32, hidden_layers=2,
                                                                branches=8),
                          epochs=epochs, seed=1, batch_size=16, lr=3e-3, infimum_lr=1e-3,
                          physics=physics)


def test_physics_mode_trains_resumes_and_reloads_with_the_state_built_in(small, tmp_path):
    net, history = nh.train(cfg(epochs=2, extra_times=10), small, tmp_path, progress=False,
                            stop_after=1)
    assert [h["epoch"] for h in history] == [1]
    net, history = nh.train(cfg(epochs=2, extra_times=10), small, tmp_path, progress=False,
                            resume=True)
    assert [h["epoch"] for h in history] == [1, 2]
    loaded, config = load_model(tmp_path)
    assert config["physics"]["extra_times"] == 10 and config["physics"]["label_fraction"] == 0
    V = torch.as_tensor(small.V[:5], dtype=torch.float32)
    t = torch.tensor(nh.TIMES[:, None], dtype=torch.float32)
    with torch.no_grad():
        y = loaded((V, t))
    assert torch.equal(y[:, 0], torch.zeros(5, 2))  # released at rest, exactly
    with torch.no_grad():
        np.testing.assert_array_equal(y.numpy(), net.eval()((V, t)).numpy())


def test_physics_mode_errors_are_named(small, tmp_path):
    with pytest.raises(ValueError, match="label_fraction"):
        nh.train(cfg(label_fraction=2.0), small, tmp_path, progress=False)
    with pytest.raises(ValueError, match="physics: .*unexpected keyword.*fields"):
        nh.train(cfg(lables=0.1), small, tmp_path / "b", progress=False)
    coupled = nh.TrainConfig("traonet", preset="cpu", epochs=1, physics={},
                             arch=dict(d_model=8, nhead=2, num_layers=1, dim_feedforward=16))
    with pytest.raises(ValueError, match="query_coupled=False"):
        nh.train(coupled, small, tmp_path / "c", progress=False)


def test_the_integral_form_takes_a_network_that_couples_its_query_times(small, tmp_path):
    arch = dict(d_model=8, nhead=2, num_layers=1, dim_feedforward=16)
    coupled = nh.TrainConfig("traonet", preset="cpu", epochs=1, arch=arch, batch_size=16,
                             physics={"form": "integral", "label_fraction": 0.5})
    net, history = nh.train(coupled, small, tmp_path, progress=False)
    assert net.query_coupled and len(history) == 1 and np.isfinite(history[0]["val_loss"])
    loaded, config = load_model(tmp_path)
    assert config["physics"]["form"] == "integral"
    with pytest.raises(ValueError, match="form must be one of"):
        nh.train(cfg(form="strong"), small, tmp_path / "b", progress=False)
