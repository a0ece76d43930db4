"""Training in DeepXDE's loop: falling loss, checkpoints, resume, divergence, load/predict."""

import csv
import json

import numpy as np
import pytest
import torch
from model_helpers import TINY

import nh_operators as nh
from nh_operators.data import generate_dataset
from nh_operators.training import load_checkpoint


@pytest.fixture(scope="module")
def small():
    return generate_dataset(100, seed=3, progress=False)


def cfg(name, epochs=4, **kw):
    return nh.TrainConfig(name, preset="cpu", arch=TINY[name], epochs=epochs, seed=7,
                          batch_size=20, **kw)


@pytest.mark.parametrize("name", sorted(nh.MODELS))
def test_every_model_trains_with_a_falling_loss(name, small, tmp_path):
    net, history = nh.train(cfg(name, epochs=8, lr=1e-2, infimum_lr=1e-3), small,
                            tmp_path, progress=False)
    assert [h["epoch"] for h in history] == list(range(1, 9))
    losses = [h["train_loss"] for h in history]
    assert losses[-1] < 0.85 * losses[0]
    assert history[-1]["val_loss"] < history[0]["val_loss"]


def test_run_directory_contents(small, tmp_path):
    _, history = nh.train(cfg("traonet", epochs=4), small, tmp_path, progress=False)
    state = load_checkpoint(tmp_path)
    assert state["epoch"] == 4
    assert state["data_checksum"] == small.checksum
    assert state["data_draw"] == small.generator["draw"] == 2
    assert small.checksum.startswith("arrays-sha256:")
    assert {"model", "optimizer", "scheduler", "rng", "config"} <= set(state)
    config = json.loads((tmp_path / "config.json").read_text())
    assert config == state["config"]
    assert config["lr"] == pytest.approx(1.4645e-3)  # the paper's TraONet value
    assert config["betas"] == [0.85, 0.98]
    with open(tmp_path / "history.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["epoch"]) for r in rows] == [1, 2, 3, 4]
    assert float(rows[1]["val_loss"]) == pytest.approx(history[1]["val_loss"])
    # stepped per iteration, the schedule is at ExpHyperbolicLR's value for x = 2
    # (N = 4, U = 300) at the end of epoch 2
    h = lambda x: np.sqrt((4 - x) / 300 * (2 - (4 + x) / 300))  # noqa: E731
    assert float(rows[1]["lr"]) == pytest.approx(
        1.4645e-3 * (1.4645e-3 / 4.5159e-5) ** (h(2) - h(0)), rel=1e-9)
    with pytest.raises(FileExistsError, match="resume"):
        nh.train(cfg("traonet", epochs=4), small, tmp_path, progress=False)


@pytest.mark.parametrize("name", ["traonet", "varonet"])
def test_resumed_run_ends_where_an_uninterrupted_one_does(name, small, tmp_path):
    full_net, full = nh.train(cfg(name), small, tmp_path / "full", progress=False)

    def kill_after_two(record, net):
        if record["epoch"] == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        nh.train(cfg(name), small, tmp_path / "killed", progress=False,
                 epoch_callback=kill_after_two)
    assert load_checkpoint(tmp_path / "killed")["epoch"] == 2
    net, resumed = nh.train(cfg(name), small, tmp_path / "killed", resume=True,
                            progress=False)
    assert [h["epoch"] for h in resumed] == [1, 2, 3, 4]
    for a, b in zip(full, resumed):
        assert a["train_loss"] == b["train_loss"]
        assert a["val_loss"] == b["val_loss"]
    for (k, a), b in zip(full_net.state_dict().items(), net.state_dict().values()):
        assert torch.equal(a, b), k


def test_wall_time_budget_stops_after_an_epoch_and_resume_finishes_the_schedule(
        small, tmp_path):
    full_net, full = nh.train(cfg("deeponet"), small, tmp_path / "full", progress=False)
    # a budget shorter than one epoch: exactly one epoch runs, its checkpoint is saved
    _, part = nh.train(cfg("deeponet"), small, tmp_path / "cut", progress=False,
                       max_minutes=1e-9)
    assert [h["epoch"] for h in part] == [1]
    assert load_checkpoint(tmp_path / "cut")["epoch"] == 1
    # resuming with the spent budget does nothing; a larger one completes the schedule
    _, again = nh.train(cfg("deeponet"), small, tmp_path / "cut", resume=True,
                        progress=False, max_minutes=1e-9)
    assert [h["epoch"] for h in again] == [1]
    net, rest = nh.train(cfg("deeponet"), small, tmp_path / "cut", resume=True,
                         progress=False)
    assert [h["val_loss"] for h in rest] == [h["val_loss"] for h in full]
    with pytest.raises(ValueError, match="max_minutes must be positive"):
        nh.train(cfg("deeponet"), small, tmp_path / "bad", max_minutes=0)
    # stop_after reproduces the cut run: same epochs, same weights
    _, cut = nh.train(cfg("deeponet"), small, tmp_path / "stop", progress=False,
                      stop_after=1)
    assert [h["val_loss"] for h in cut] == [part[0]["val_loss"]]
    with pytest.raises(ValueError, match=r"stop_after must be an epoch in \[1, 4\]"):
        nh.train(cfg("deeponet"), small, tmp_path / "bad", stop_after=5)


def test_resume_refuses_another_config_or_dataset(small, tmp_path):
    nh.train(cfg("deeponet", epochs=1), small, tmp_path, progress=False)
    with pytest.raises(ValueError, match=r"differs in \['seed'\]"):
        nh.train(nh.TrainConfig("deeponet", preset="cpu", arch=TINY["deeponet"],
                                epochs=1, seed=8, batch_size=20),
                 small, tmp_path, resume=True, progress=False)
    other = generate_dataset(30, seed=4, progress=False)
    with pytest.raises(ValueError, match="checksum"):
        nh.train(cfg("deeponet", epochs=1), other, tmp_path, resume=True,
                 progress=False)


def test_non_finite_loss_stops_and_keeps_the_last_good_checkpoint(small, tmp_path):
    def poison(record, net):
        if record["epoch"] == 2:
            with torch.no_grad():
                next(net.parameters()).fill_(float("nan"))

    with pytest.raises(nh.TrainingDiverged, match="non-finite loss in epoch 3.*checkpoint of epoch 2 is kept"):
        nh.train(cfg("deeponet"), small, tmp_path, progress=False, epoch_callback=poison)
    state = load_checkpoint(tmp_path)
    # the checkpoint was written before the callback poisoned the weights
    assert state["epoch"] == 2
    assert all(torch.all(torch.isfinite(v)) for v in state["model"].values()
               if v.is_floating_point())


def test_config_errors_are_named():
    with pytest.raises(ValueError, match="upper_bound"):
        nh.TrainConfig("traonet", epochs=400).resolved()
    with pytest.raises(ValueError, match="unknown scheduler"):
        nh.TrainConfig("traonet", scheduler="cosine").resolved()
    with pytest.raises(ValueError, match="dtype"):
        nh.TrainConfig("traonet", dtype="float16").resolved()
    with pytest.raises(ValueError, match="amp"):
        nh.train(nh.TrainConfig("traonet", amp=True, device="cpu"), None, "unused")


def test_float64_training_and_load_model_predict_round_trip(small, tmp_path):
    net, _ = nh.train(cfg("deeponet", epochs=1, dtype="float64"), small, tmp_path,
                      progress=False)
    loaded, config = nh.load_model(tmp_path)
    assert config["dtype"] == "float64" and not loaded.training
    assert next(loaded.parameters()).dtype == torch.float64
    t = np.linspace(0, 2, 13)
    q, p = nh.predict(loaded, small.V[:30], t, batch_size=7)
    assert q.shape == p.shape == (30, 13)
    with torch.no_grad():
        direct = net.eval()((torch.as_tensor(small.V[:30]), torch.as_tensor(t[:, None])))
    np.testing.assert_allclose(q, direct[..., 0].numpy(), rtol=0, atol=1e-12)
    q1, p1 = nh.predict(loaded, small.V[5], t[:, None])
    np.testing.assert_allclose(q1, q[5], atol=1e-12)


def test_predict_errors_are_named():
    net = nh.build_model("deeponet", "cpu")
    with pytest.raises(ValueError, match="t must have shape"):
        nh.predict(net, np.zeros((2, 100)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="finite"):
        nh.predict(net, np.full((2, 100), np.nan), np.zeros(3))
    with pytest.raises(ValueError, match="batch_size"):
        nh.predict(net, np.zeros((2, 100)), np.zeros(3), batch_size=0)
    with pytest.raises(ValueError, match=r"V must have shape \(batch, 100\)"):
        nh.predict(net, np.zeros((2, 50)), np.zeros(3))


def test_kl_column_is_the_papers_beta_term_per_output():
    from nh_operators.data import OperatorData

    torch.manual_seed(0)
    net = nh.build_model("varonet", "cpu", **TINY["varonet"]).eval()
    V = np.random.default_rng(0).uniform(-2, 2, (4, 100)).astype(np.float32)
    t = np.linspace(0, 2, 10, dtype=np.float32)[:, None]
    y = np.zeros((4, 10, 2), np.float32)
    data = OperatorData((V, t), y, (V, t), y, beta=0.5)
    out = net((torch.as_tensor(V), torch.as_tensor(t)))

    class Model:  # what DeepXDE hands to Data.losses
        pass

    Model.net = net
    mse, kl = data.losses_test(torch.as_tensor(y), out, torch.nn.functional.mse_loss,
                               None, Model)
    assert mse.item() == pytest.approx((out**2).mean().item())
    # Σ over the 20 outputs of error² + β KL, per sample, divided by 20
    assert kl.item() == pytest.approx(0.5 * net.kl.item() / 20)
    assert net.kl.item() > 0


def test_divergence_in_the_first_epoch_says_there_is_no_checkpoint(small, tmp_path):
    import copy

    bad = copy.copy(small)
    bad.q = np.full_like(small.q, np.nan)
    with pytest.raises(nh.TrainingDiverged, match=r"iteration 1\);.*no epoch finished"):
        nh.train(cfg("deeponet"), bad, tmp_path, progress=False)
    assert not (tmp_path / "checkpoint.pt").exists()
