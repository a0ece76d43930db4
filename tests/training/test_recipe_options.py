"""The training options of the CPU recipe: LogCosh, the weight average (EMA)."""

import math

import numpy as np
import pytest
import torch
from model_helpers import TINY

import nh_operators as nh
from nh_operators.data import generate_dataset
from nh_operators.training import load_checkpoint, load_model
from nh_operators.training.averaging import WeightAverage
from nh_operators.training.losses import LOSSES, log_cosh


def test_log_cosh_matches_its_definition_and_both_limits():
    x = torch.linspace(-30, 30, 601, dtype=torch.float64)
    zero = torch.zeros_like(x)
    direct = torch.log(torch.cosh(x))
    assert float(log_cosh(zero, x)) == pytest.approx(float(direct.mean()), rel=1e-11)
    small = torch.tensor([1e-4, -3e-4], dtype=torch.float64)
    assert float(log_cosh(torch.zeros(2, dtype=torch.float64), small)) == pytest.approx(
        float((small ** 2 / 2).mean()), rel=1e-7)
    big = torch.tensor([1e3], dtype=torch.float64)  # cosh overflows; log cosh does not
    assert float(log_cosh(torch.zeros(1, dtype=torch.float64), big)) == pytest.approx(
        1e3 - math.log(2), rel=1e-15)
    assert set(LOSSES) == {"mse", "logcosh"}


def test_weight_average_follows_the_warm_up_formula_exactly():
    net = torch.nn.Sequential(torch.nn.Linear(2, 2), torch.nn.BatchNorm1d(2))
    w0 = net[0].weight.detach().clone()
    avg = WeightAverage(net, 0.9)
    with torch.no_grad():
        net[0].weight.fill_(1.0)
    net[1].num_batches_tracked.fill_(5)
    for _ in range(20):
        avg.update(net)
    keep = np.prod([min(0.9, (1 + n) / (10 + n)) for n in range(1, 21)])
    expected = keep * w0 + (1 - keep) * 1.0
    assert torch.allclose(avg.shadow["0.weight"], expected, rtol=0, atol=1e-6)
    assert int(avg.shadow["1.num_batches_tracked"]) == 5  # integers are copied
    assert avg.rate(1) == pytest.approx(2 / 11) and avg.rate(10_000) == 0.9
    own = net[0].weight.detach().clone()
    with avg.applied(net):
        assert torch.equal(net[0].weight, avg.shadow["0.weight"])
    assert torch.equal(net[0].weight, own)
    other = WeightAverage(net, 0.5)
    other.load_state_dict(avg.state_dict())
    assert other.steps == 20 and other.decay == 0.9
    assert torch.equal(other.shadow["0.weight"], avg.shadow["0.weight"])
    with pytest.raises(ValueError, match="decay"):
        WeightAverage(net, 1.0)


@pytest.fixture(scope="module")
def small():
    return generate_dataset(60, seed=5, progress=False)


def cfg(**kw):
    return nh.TrainConfig("traonet", preset="cpu", arch=TINY["traonet"], epochs=3, seed=2,
                          batch_size=20, **kw)


def test_ema_run_saves_scores_and_resumes_the_average(small, tmp_path):
    net, full = nh.train(cfg(ema=0.99, loss="logcosh"), small, tmp_path / "full",
                         progress=False)
    state = load_checkpoint(tmp_path / "full")
    assert state["average"]["steps"] == 3 * 3  # 48 training rows: batches 20, 20, 8
    assert state["train_rows"] == 48
    loaded, config = load_model(tmp_path / "full")
    assert config["ema"] == 0.99 and config["loss"] == "logcosh"
    for key, value in loaded.state_dict().items():  # train returns the average too
        assert torch.equal(value, net.state_dict()[key]), key
        assert torch.equal(value, state["model"][key]), key
    assert any(not torch.equal(state["model"][k], v)
               for k, v in state["train_model"].items())
    # the recorded validation loss is the average's
    _, val = small.split_indices()
    q, p = nh.predict(loaded, small.V[val], small.t)
    own = np.mean(((q - small.q[val]) ** 2 + (p - small.p[val]) ** 2) / 2)
    assert own == pytest.approx(full[-1]["val_loss"], rel=1e-5)
    nh.train(cfg(ema=0.99, loss="logcosh"), small, tmp_path / "cut", progress=False,
             stop_after=1)
    net2, resumed = nh.train(cfg(ema=0.99, loss="logcosh"), small, tmp_path / "cut",
                             resume=True, progress=False)
    assert [r["val_loss"] for r in resumed] == [r["val_loss"] for r in full]
    for key, value in net.state_dict().items():
        assert torch.equal(value, net2.state_dict()[key]), key


def test_recipe_option_errors_are_named():
    with pytest.raises(ValueError, match="unknown loss 'l1'"):
        cfg(loss="l1").resolved()
    with pytest.raises(ValueError, match="ema must be"):
        cfg(ema=1.5).resolved()


def test_reference_recipe_trains_the_reference_variant_and_reloads_it(small, tmp_path):
    arch = dict(d_model=16, nhead=2, num_layers=1, dim_feedforward=32)
    config = nh.TrainConfig("traonet", preset="cpu", arch=arch, epochs=2, seed=2,
                            batch_size=20, variant="reference", recipe="reference")
    resolved = config.resolved()
    assert resolved["betas"] == [0.9, 0.999] and resolved["scheduler_step"] == "epoch"
    assert (resolved["lr"], resolved["infimum_lr"]) == (1.4645e-3, 3.0497e-7)
    net, history = nh.train(config, small, tmp_path, progress=False)
    assert type(net).__name__ == "ReferenceTraONet"
    # stepped per epoch: the lr logged at the end of epoch 1 is the curve's at x = 1
    h = lambda x: math.sqrt((2 - x) / 300 * (2 - (2 + x) / 300))  # noqa: E731
    expected = 1.4645e-3 * (1.4645e-3 / 3.0497e-7) ** (h(1) - h(0))
    assert history[0]["lr"] == pytest.approx(expected, rel=1e-9)
    loaded, saved = load_model(tmp_path)
    assert saved["variant"] == "reference" and saved["recipe"] == "reference"
    x = (torch.rand(2, 100), torch.linspace(0, 2, 5)[:, None])
    net.eval()
    assert torch.equal(loaded(x), net(x))


def test_a_given_value_wins_over_the_recipe_and_bad_names_are_named():
    config = nh.TrainConfig("traonet", recipe="reference", betas=(0.8, 0.9),
                            scheduler_step="iteration").resolved()
    assert config["betas"] == [0.8, 0.9] and config["scheduler_step"] == "iteration"
    with pytest.raises(ValueError, match="unknown recipe 'paper'"):
        nh.TrainConfig("traonet", recipe="paper").resolved()
    with pytest.raises(ValueError, match="unknown model 'fno' for variant 'reference'"):
        nh.TrainConfig("fno", variant="reference").resolved()
    with pytest.raises(ValueError, match="scheduler_step must be"):
        nh.TrainConfig("fno", scheduler_step="batch").resolved()
