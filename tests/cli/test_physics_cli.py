"""``nh-operators train --physics KEY=VALUE ...``: the physics-informed mode from the CLI."""

import json
import re

import numpy as np
import pytest
import torch

import nh_operators as nh
from nh_operators.cli import main
from nh_operators.training import load_model


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    path = tmp_path_factory.mktemp("physics") / "d.h5"
    assert main(["generate", "--size", "40", "--seed", "3", "--out", str(path),
                 "--quiet"]) == 0
    return path


def base(data, out):
    return ["train", "--model", "deeponet", "--data", str(data), "--epochs", "1",
            "--seed", "1", "--out", str(out), "--batch-size", "16", "--quiet",
            "--arch", "hidden_size=16", "--arch", "branches=4"]


def test_physics_flag_reaches_the_config_and_builds_the_state_in(data, tmp_path, capsys):
    run = tmp_path / "run"
    assert main(base(data, run) + ["--physics", "label_fraction=0.25", "energy=0.1",
                                   "--physics", "extra_times=5"]) == 0
    assert "1 epochs" in capsys.readouterr().out
    physics = json.loads((run / "config.json").read_text())["physics"]
    assert physics["label_fraction"] == 0.25 and physics["energy"] == 0.1
    assert physics["extra_times"] == 5 and physics["residual"] == 1.0
    net, _ = load_model(run)
    V = torch.as_tensor(nh.load_dataset(str(data)).V[:3], dtype=torch.float32)
    with torch.no_grad():
        y = net((V, torch.tensor([[0.0], [1.0]])))
    np.testing.assert_array_equal(y[:, 0].numpy(), np.zeros((3, 2)))  # released at rest
    assert float(y[:, 1].abs().sum()) > 0  # ... and moves afterwards


def test_flag_alone_is_residual_only_and_absent_flag_is_data_driven(data, tmp_path):
    assert main(base(data, tmp_path / "a") + ["--physics"]) == 0
    physics = json.loads((tmp_path / "a" / "config.json").read_text())["physics"]
    assert physics["label_fraction"] == 0.0 and physics["residual"] == 1.0
    assert main(base(data, tmp_path / "b")) == 0
    assert json.loads((tmp_path / "b" / "config.json").read_text())["physics"] is None


@pytest.mark.parametrize("flags, message", [
    (["--physics", "label_fraction"], "expected KEY=VALUE, got 'label_fraction'"),
    (["--physics", "=0.1"], "expected KEY=VALUE"),
    (["--physics", "lables=0.1"], "physics: .*lables.*fields"),
    (["--physics", "label_fraction=2"], "label_fraction must lie in"),
    (["--physics", "energy=1", "energy=2"], "--physics gives 'energy' twice"),
])
def test_bad_physics_options_fail_in_one_line(data, tmp_path, capsys, flags, message):
    assert main(base(data, tmp_path / "r") + flags) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    assert re.search(message, err), err
