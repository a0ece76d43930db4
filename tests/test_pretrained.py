import json

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.cli import main
from nh_operators.checkpoint import load_checkpoint
from nh_operators.pretrained import (WEIGHTS, available_pretrained, export_pretrained,
                                     pretrained)


def test_shipped_deeponet_loads_offline_with_its_metrics():
    assert "deeponet" in available_pretrained()
    model = pretrained("deeponet")
    assert model.name == "deeponet" and model.config["epochs"] == model.metrics["epochs"]
    shipped = load_checkpoint(WEIGHTS / "deeponet")
    assert model.metrics["data_checksum"] == shipped["data_checksum"]
    assert shipped["data_checksum"].startswith("sha256:") and "optimizer" not in shipped
    assert any(c.startswith("nh-operators train --model deeponet") for c in
               model.metrics["commands"])
    V = nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS)[None]
    q, p = model(V, nh.TIMES)
    loss = 0.5 * (np.mean((q[0] - nh.PHYSICAL_POTENTIALS["sho"].exact(nh.TIMES)[0]) ** 2)
                  + np.mean((p[0] - nh.PHYSICAL_POTENTIALS["sho"].exact(nh.TIMES)[1]) ** 2))
    # the shipped metrics say what this model scores on the SHO: check it reproduces
    assert loss == pytest.approx(model.metrics["evaluation"]["physical"]["sho"], rel=1e-5)


def test_shipped_weights_stay_small():
    size = sum(f.stat().st_size for f in WEIGHTS.rglob("*") if f.is_file())
    assert size < 25e6


def test_unknown_name_lists_the_available():
    with pytest.raises(ValueError, match="no pretrained model 'nope'; available: .*deeponet"):
        pretrained("nope")


def test_export_round_trip_through_the_cli(tmp_path, capsys):
    data, run, out = tmp_path / "d.h5", tmp_path / "run", tmp_path / "weights" / "tiny"
    assert main(["generate", "--size", "20", "--seed", "5", "--out", str(data), "--quiet"]) == 0
    assert main(["train", "--model", "deeponet", "--data", str(data), "--epochs", "1",
                 "--out", str(run), "--batch-size", "8", "--quiet", "--arch", "hidden_size=8",
                 "--arch", "branches=2"]) == 0
    assert main(["export", "--run", str(run), "--out", str(out), "--command", "make it"]) == 0
    assert "exported" in capsys.readouterr().out
    assert {f.name for f in out.iterdir()} == {"checkpoint.pt", "config.json", "history.csv",
                                               "metrics.json"}
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["commands"] == ["make it"] and metrics["epochs"] == 1
    assert (out / "checkpoint.pt").stat().st_mode & 0o044 == 0o044  # readable by others
    net_run, _ = nh.load_model(run)
    net_out, _ = nh.load_model(out)
    V = np.tile(nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS), (2, 1))
    np.testing.assert_array_equal(nh.predict(net_run, V, nh.TIMES)[0],
                                  nh.predict(net_out, V, nh.TIMES)[0])
    with pytest.raises(ValueError, match="has no entry for 'deeponet'"):
        (tmp_path / "r.json").write_text(json.dumps({"methods": {}}))
        export_pretrained(run, out, report=tmp_path / "r.json")
