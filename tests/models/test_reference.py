"""The reference variants compute the authors' networks, weight for weight.

``data/reference-5c4cbd8-small.npz`` holds what the authors' own networks (their
``model.py`` at 5c4cbd8) compute at small sizes, in float64, with their ``state_dict``s
(``data/reference-5c4cbd8-README.md`` says how it was made). No reference code is used.
"""

import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch

import nh_operators as nh
from nh_operators.models import (REFERENCE_MODELS, VARIANTS, MambONet, ReferenceTraONet,
                                 TraONet, build_model, count_parameters, from_reference,
                                 predict, reference_arguments)
from nh_operators.models._reference_layers import PositionalEncoding
from nh_operators.models.presets import REFERENCE_ARCHITECTURES

from nh_operators._backend import ensure_pytorch_backend  # noqa: E402
dde = ensure_pytorch_backend()

DATA = Path(__file__).parent / "data"
FIXTURE = np.load(DATA / "reference-5c4cbd8-small.npz")
META = json.loads((DATA / "reference-5c4cbd8-small.json").read_text())
NAMES = ["deeponet", "varonet", "traonet", "mambonet"]
GRID = torch.tensor(nh.TIMES)[:, None]

#: The authors' run configs (the paper's grid-search optima), under their key names.
PAPER_NET_CONFIGS = {
    "deeponet": dict(nodes=128, layers=3, branches=10),
    "varonet": dict(hidden_size=512, num_layers=4, latent_size=30, dropout=0.0),
    "traonet": dict(d_model=64, nhead=8, num_layers=3, dim_feedforward=512, dropout=0.0),
    "mambonet": dict(d_model=128, num_layers1=4, n_head=4, num_layers2=4, d_ff=1024),
}

#: Other sizes than the fixture's, under the authors' key names.
OTHER_SIZES = {
    "deeponet": dict(nodes=12, layers=4, branches=7),
    "varonet": dict(hidden_size=10, num_layers=3, latent_size=5, dropout=0.1,
                    kl_weight=0.05),
    "traonet": dict(d_model=24, nhead=3, num_layers=1, dim_feedforward=40, dropout=0.1),
    "mambonet": dict(d_model=24, num_layers1=3, n_head=2, num_layers2=1, d_ff=20),
}


def fixture_state(name):
    prefix = f"{name}/state/"
    return {k[len(prefix):]: FIXTURE[k] for k in FIXTURE.files if k.startswith(prefix)}


def run(net, V):
    with torch.no_grad():
        return net((torch.as_tensor(V), GRID.to(next(net.parameters()).dtype)))


def test_the_fixture_times_are_the_grid():
    assert np.abs(FIXTURE["t"] - nh.TIMES[None]).max() < 1e-15


@pytest.mark.parametrize("name", NAMES)
def test_from_reference_reproduces_the_authors_network(name):
    net = from_reference(name, fixture_state(name), **META["sizes"][name])
    net = nh.models.cast_network(net, torch.float64).eval()
    assert count_parameters(net) == META[f"{name}_param_count"]
    y = run(net, FIXTURE["V"])
    err_q = (y[..., 0] - torch.tensor(FIXTURE[f"{name}/q"])).abs().max().item()
    err_p = (y[..., 1] - torch.tensor(FIXTURE[f"{name}/p"])).abs().max().item()
    assert err_q <= 1e-10 and err_p <= 1e-10, (err_q, err_p)
    assert float(torch.tensor(FIXTURE[f"{name}/q"]).abs().max()) > 1e-2  # not all zeros
    if name == "varonet":
        for key in ("mu", "logvar"):
            err = (getattr(net, key) - torch.tensor(FIXTURE[f"varonet/{key}"])).abs().max()
            assert getattr(net, key).shape == (4, 4, 6) and err.item() <= 1e-10, key


def test_the_reference_positional_table_is_the_authors():
    pe = PositionalEncoding(16).double().pe
    assert torch.equal(pe, torch.tensor(fixture_state("traonet")["trunk_net.pos_encoder.pe"]))


def test_the_time_encoding_reads_the_table_on_the_grid_and_is_continuous_off_it():
    enc = PositionalEncoding(16).double()
    on = enc.at(GRID[:, 0].double() * 99 / 2)
    assert torch.equal(on, enc.pe[0])
    near = enc.at(torch.tensor([10.001, 9.999, 0.5], dtype=torch.float64))
    assert (near[:2] - enc.pe[0, 10]).abs().max() < 2e-3
    assert (near[2] - enc.pe[0, 0]).abs().max() > 0.1  # a true half step moves


@pytest.mark.parametrize("name", NAMES)
def test_round_trip_at_other_sizes_and_seeds(name, tmp_path):
    config = OTHER_SIZES[name]
    with torch.random.fork_rng():
        torch.manual_seed(1234 + NAMES.index(name))
        original = build_model(name, "cpu", variant="reference",
                               **reference_arguments(name, **config)).double().eval()
    again = from_reference(name, original.state_dict(), **config)
    assert next(again.parameters()).dtype == torch.float64 and not again.training
    V = np.random.default_rng(3).uniform(-2, 2, (5, 100))
    assert torch.equal(run(original, V), run(again, V))
    # a float32 checkpoint on disk gives a float32 network with the same weights
    torch.save(original.float().state_dict(), tmp_path / "theirs.pt")
    from_disk = from_reference(name, tmp_path / "theirs.pt", **config)
    assert next(from_disk.parameters()).dtype == torch.float32
    assert torch.equal(run(original.float().eval(), V.astype(np.float32)),
                       run(from_disk, V.astype(np.float32)))


@pytest.mark.parametrize("name", NAMES)
def test_paper_sizes_give_the_authors_parameter_counts(name):
    assert reference_arguments(name, **PAPER_NET_CONFIGS[name]) == {
        **REFERENCE_ARCHITECTURES["paper"][name],
        **({"dropout": 0.0} if "dropout" in PAPER_NET_CONFIGS[name] else {})}
    with torch.device("meta"):
        net = build_model(name, "paper", variant="reference")
    assert count_parameters(net) == META["paper_param_counts"][name]


def test_the_deeponet_width_is_the_authors_list_bug():
    assert reference_arguments("deeponet", nodes=16, layers=3, branches=5) == {
        "hidden_size": 32, "branches": 5}
    with pytest.raises(ValueError, match="layers >= 2"):
        reference_arguments("deeponet", nodes=16, layers=1)


def test_errors_name_what_is_wrong():
    state = fixture_state("traonet")
    sizes = META["sizes"]["traonet"]
    with pytest.raises(ValueError, match=r"no net_config key\(s\) \['n_head'\]"):
        from_reference("traonet", state, n_head=4, **sizes)
    with pytest.raises(ValueError, match="no reference variant of 'fno'"):
        from_reference("fno", state)
    partial = {k: v for k, v in state.items() if k != "trunk_net.fc.bias"}
    with pytest.raises(ValueError, match=r"missing key\(s\) \['trunk_net.fc.bias'\]"):
        from_reference("traonet", partial, **sizes)
    with pytest.raises(ValueError, match=r"unexpected key\(s\) \['extra'\]"):
        from_reference("traonet", {**state, "extra": np.zeros(1)}, **sizes)
    with pytest.raises(ValueError, match=r"shape mismatch.*branch_net.embedding.weight: "
                                         r"checkpoint \(16, 1\), network \(32, 1\)"):
        from_reference("traonet", state, **{**sizes, "d_model": 32})
    with pytest.raises(TypeError, match="state_dict"):
        from_reference("traonet", [1, 2])
    with pytest.raises(ValueError, match="unknown variant 'theirs'"):
        build_model("traonet", "cpu", variant="theirs")
    with pytest.raises(ValueError, match="unknown model 'fno' for variant 'reference'"):
        build_model("fno", "cpu", variant="reference")


def test_the_default_variant_is_unchanged():
    assert type(build_model("traonet", "cpu")) is TraONet
    assert type(build_model("mambonet", "cpu", variant="ours")) is MambONet
    assert type(build_model("traonet", "cpu", variant="reference")) is ReferenceTraONet
    assert set(VARIANTS["reference"][0]) == set(REFERENCE_MODELS) == set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_reference_variants_train_in_deepxdes_shape_convention(name):
    torch.manual_seed(0)
    net = build_model(name, "cpu", variant="reference").train()
    V = torch.rand(3, 100) * 4 - 2
    y = net((V, GRID.float()))
    assert y.shape == (3, 100, 2) and y.dtype == torch.float32
    loss = y.square().mean() + (net.kl if name == "varonet" else 0.0)
    loss.backward()
    grads = {k: p.grad for k, p in net.named_parameters()}
    unused = {k for k in grads if "encoder_layer." in k or "decoder_layer." in k
              or k.endswith("fc.weight") and name in ("traonet", "mambonet")
              or k.endswith("fc.bias") and name in ("traonet", "mambonet")}
    assert all(grads[k] is None for k in unused)  # the authors' unused template layers
    used = [g for k, g in grads.items() if k not in unused]
    assert all(g is not None and torch.isfinite(g).all() for g in used)
    assert sum(float(g.abs().sum()) for g in used) > 0


def test_reference_varonet_samples_in_training_and_uses_the_mean_in_eval():
    torch.manual_seed(0)
    net = build_model("varonet", "cpu", variant="reference", hidden_size=8, latent_dim=3)
    V = torch.rand(2, 100)
    a, b = net((V, GRID.float())), net((V, GRID.float()))
    assert not torch.equal(a, b) and net.kl.ndim == 0 and float(net.kl.detach()) > 0
    net.eval()
    assert torch.equal(net((V, GRID.float())), net((V, GRID.float())))
    assert net.mu.shape == net.logvar.shape == (2, 4, 3)


def test_reference_traonet_trains_in_deepxdes_own_loop():
    rng = np.random.default_rng(0)
    V = rng.uniform(-2, 2, (8, 100)).astype(np.float32)
    y = rng.normal(size=(8, 100, 2)).astype(np.float32)
    t = nh.TIMES[:, None].astype(np.float32)
    data = dde.data.TripleCartesianProd((V[:6], t), y[:6], (V[6:], t), y[6:])
    torch.manual_seed(0)
    net = build_model("traonet", "cpu", variant="reference", d_model=16, nhead=2,
                      num_layers=1, dim_feedforward=32)
    model = dde.Model(data, net)
    model.compile("adam", lr=1e-3)
    history, _ = model.train(iterations=3, batch_size=6, display_every=1, verbose=0)
    assert np.isfinite(history.loss_train).all()


def test_predict_runs_the_coupled_reference_decoders_on_the_grid():
    torch.manual_seed(0)
    net = build_model("traonet", "cpu", variant="reference")
    assert net.query_coupled and not build_model("deeponet", "cpu",
                                                  variant="reference").query_coupled
    V = 2 - 8 * nh.SENSORS * (1 - nh.SENSORS) * np.array([[1.0], [0.6]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning: off the grid it interpolates the grid
        q_grid, _ = predict(net, V, nh.TIMES)
        q_sub, _ = predict(net, V, nh.TIMES[[10, 60]])
    np.testing.assert_allclose(q_sub, q_grid[:, [10, 60]], rtol=0, atol=1e-12)
