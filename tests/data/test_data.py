import h5py
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import nh_operators as nh
from nh_operators.data import (
    DATASET_PRESETS as PRESETS,
    Dataset,
    generate_dataset,
    label_potentials,
    load_dataset,
)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    path = tmp_path_factory.mktemp("data") / "small.h5"
    return generate_dataset(60, seed=5, path=path, chunk=25, progress=False), path


def test_shapes_grid_and_rebuild(small):
    ds, _ = small
    assert len(ds) == 60
    assert ds.V.shape == ds.q.shape == ds.p.shape == (60, 100)
    np.testing.assert_array_equal(ds.x, nh.SENSORS)
    np.testing.assert_array_equal(ds.t, nh.TIMES)
    # the sensors are values of the true potential rebuilt from the stored control points
    np.testing.assert_allclose(ds.potentials().V(nh.SENSORS), ds.V, rtol=0, atol=1e-14)
    pot = ds.potential(7)
    np.testing.assert_allclose(pot.V(ds.x), ds.V[7], atol=1e-14)
    assert pot.dV(np.array([0.0]))[0] < 0


def test_labels_match_independent_dop853_and_conserve_energy(small):
    ds, _ = small
    for i in range(0, 60, 12):
        pot = ds.potential(i)
        sol = solve_ivp(lambda _, y: (y[1], -pot.dV(y[0])), (0, 2), (0.0, 0.0), method="DOP853",
                        t_eval=ds.t, rtol=1e-13, atol=1e-13)
        l_tot = 0.5 * np.mean((sol.y[0] - ds.q[i]) ** 2 + (sol.y[1] - ds.p[i]) ** 2)
        assert l_tot <= 1e-12
    energy = np.array([0.5 * ds.p[i] ** 2 + ds.potential(i).V(ds.q[i]) for i in range(len(ds))])
    assert np.max(np.abs(energy - nh.V0)) <= 1e-10


def test_same_seed_same_arrays_and_bytes_any_chunk(small, tmp_path):
    ds, path = small
    other = tmp_path / "again.h5"
    ds2 = generate_dataset(60, seed=5, path=other, chunk=60, progress=False)
    for name in ("V", "q", "p", "control_q", "control_V", "length_scale", "n_grf"):
        np.testing.assert_array_equal(getattr(ds, name), getattr(ds2, name))
    assert ds.attrs["checksum"] == ds2.attrs["checksum"]
    third = tmp_path / "third.h5"
    generate_dataset(60, seed=5, path=third, chunk=25, progress=False)
    assert path.read_bytes() == third.read_bytes()
    in_memory = generate_dataset(60, seed=5, progress=False)
    np.testing.assert_array_equal(in_memory.q, ds.q)


def test_different_seed_differs(small):
    ds, _ = small
    assert not np.array_equal(generate_dataset(5, seed=6, progress=False).V, ds.V[:5])


def test_round_trip_attributes(small):
    ds, path = small
    again = load_dataset(path)
    np.testing.assert_array_equal(again.q, ds.q)
    assert again.attrs["seed"] == 5 and again.attrs["size"] == 60
    assert again.attrs["generator"]["omega"] == 0.05
    assert again.attrs["version"] == nh.__version__
    assert again.attrs["checksum"].startswith("sha256:")


def test_corrupted_file_fails_checksum(small, tmp_path):
    _, path = small
    bad = tmp_path / "bad.h5"
    bad.write_bytes(path.read_bytes())
    with h5py.File(bad, "r+") as f:
        f["q"][3, 4] += 1e-9
    with pytest.raises(ValueError, match="checksum mismatch"):
        load_dataset(bad)
    assert load_dataset(bad, verify=False).q.shape == (60, 100)


def test_missing_and_foreign_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_dataset(tmp_path / "nope.h5")
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["V"] = np.zeros((2, 100))
    with pytest.raises(ValueError, match="not an nh-operators dataset"):
        load_dataset(foreign)


def test_resume_after_interruption_gives_identical_file(small, tmp_path, monkeypatch):
    ds, path = small
    target = tmp_path / "resumed.h5"
    import nh_operators.data.generate as data_mod

    calls = {"n": 0}
    original = data_mod.SampleSource.take

    def flaky(self, n, drops=None):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        return original(self, n, drops)

    monkeypatch.setattr(data_mod.SampleSource, "take", flaky)
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(60, seed=5, path=target, chunk=25, progress=False)
    assert not target.exists()
    with h5py.File(str(target) + ".partial", "r") as f:
        assert int(f.attrs["rows_done"]) == 25
    monkeypatch.setattr(data_mod.SampleSource, "take", original)
    resumed = generate_dataset(60, seed=5, path=target, chunk=25, progress=False)
    np.testing.assert_array_equal(resumed.q, ds.q)
    assert resumed.attrs["checksum"] == ds.attrs["checksum"]
    assert not (tmp_path / "resumed.h5.partial").exists()


def test_invalid_samples_are_dropped_counted_and_topped_up():
    # an energy tolerance no label meets except the easiest ones forces drops
    ds = generate_dataset(10, seed=3, progress=False, energy_tol=1e-13)
    assert len(ds) == 10
    assert ds.attrs["n_dropped"] == ds.attrs["dropped"].get("energy drift", 0) > 0
    q, p, reasons = label_potentials(ds.potentials(), energy_tol=1e-13)
    assert all(r == "" for r in reasons)


def test_to_deepxde_triple_cartesian_product(small):
    ds, _ = small
    data = ds.to_deepxde()
    import deepxde as dde

    assert isinstance(data, dde.data.TripleCartesianProd)
    assert data.train_x[0].shape == (48, 100) and data.train_x[1].shape == (100, 1)
    assert data.train_y.shape == (48, 100, 2) and data.test_y.shape == (12, 100, 2)
    assert data.train_x[0].dtype == np.float32
    train, val = ds.split_indices()
    assert len(np.intersect1d(train, val)) == 0 and len(train) + len(val) == 60
    np.testing.assert_allclose(data.train_y[:, :, 0], ds.q[train], rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(data.test_x[0], ds.V[val], rtol=1e-6)
    with pytest.raises(ValueError, match="train_fraction"):
        ds.split_indices(1.5)


def test_bad_arguments():
    with pytest.raises(ValueError, match="positive integer"):
        generate_dataset(0, seed=1)
    with pytest.raises(ValueError, match="omega"):
        generate_dataset(3, seed=1, omega=0.5)


def test_presets_are_the_papers():
    assert PRESETS["standard"] == {"size": 10_000, "seed": 8407}
    assert PRESETS["extended"] == {"size": 100_000, "seed": 8407}
    assert PRESETS["test"] == {"size": 4_000, "seed": 42}
    assert issubclass(Dataset, object)


# ------------------------------------------ the reference code's distribution (batch)


def test_batch_normalisation_spans_the_pool_not_each_potential():
    from nh_operators.potentials import BoundedPotentialSpace

    space = BoundedPotentialSpace(seed=3, normalization="batch", pool=400)
    feats = space.random(399)
    assert space.cursor == 400 and space.skipped == 1  # the pool's minimum maps to V0
    values = feats[:, 8:][np.isfinite(feats[:, 8:])]
    assert values.min() == -2.0 and values.max() < 2.0  # -V0 is reached once, in the pool
    spans = np.nanmax(feats[:, 8:], axis=1) - np.nanmin(feats[:, 8:], axis=1)
    assert np.median(spans) < 2.0  # per-potential normalisation would give 3.8 every time
    with pytest.raises(ValueError, match="the pool of 400 candidates is used up"):
        space.random(1)


def test_paper_test_recipe_matches_the_reference_codes_statistics():
    # measured on the reference code's test set (DESIGN §5): interior control values of
    # mean ≈ 0.11 and std ≈ 0.49
    from nh_operators.potentials import BoundedPotentialSpace

    space = BoundedPotentialSpace(np.random.default_rng(42), normalization="batch", pool=6250)
    values = space.random(5000)[1000:, 8:]
    values = values[np.isfinite(values)]
    assert abs(values.mean() - 0.11) < 0.02 and abs(values.std() - 0.49) < 0.02


def test_batch_datasets_are_reproducible_resume_and_skip(tmp_path, monkeypatch):
    kwargs = dict(normalization="batch", pool=80)
    whole = generate_dataset(40, seed=9, progress=False, **kwargs)
    assert whole.attrs["generator"]["normalization"] == "batch"
    assert whole.attrs["generator"]["pool"] == 80
    chunked = generate_dataset(40, seed=9, path=tmp_path / "a.h5", chunk=7, progress=False,
                               **kwargs)
    np.testing.assert_array_equal(chunked.q, whole.q)
    # the last 30 of 40 (the paper's test set is the last 4,000 of 5,000)
    tail = generate_dataset(30, seed=9, skip=10, progress=False, **kwargs)
    np.testing.assert_array_equal(tail.V, whole.V[10:])
    # an interrupted batch run resumes from its cursor to the same bytes
    import nh_operators.data.generate as generate_module

    original, calls = generate_module.SampleSource.take, {"n": 0}

    def flaky(self, n, drops=None):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        return original(self, n, drops)

    monkeypatch.setattr(generate_module.SampleSource, "take", flaky)
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(30, seed=9, skip=10, path=tmp_path / "r.h5", chunk=10,
                         progress=False, **kwargs)
    monkeypatch.setattr(generate_module.SampleSource, "take", original)
    resumed = generate_dataset(30, seed=9, skip=10, path=tmp_path / "r.h5", chunk=10,
                               progress=False, **kwargs)
    np.testing.assert_array_equal(resumed.V, whole.V[10:])


def test_paper_presets_and_their_default_pool():
    from nh_operators.data import preset_kwargs

    assert preset_kwargs("paper-standard") == {"normalization": "batch", "pool": 12_500}
    assert preset_kwargs("paper-test") == {"normalization": "batch", "pool": 6_250,
                                           "skip": 1_000}
    assert PRESETS["standard"] is PRESETS["alg1-standard"]
    ds = generate_dataset(8, seed=1, normalization="batch", progress=False)
    assert ds.attrs["generator"]["pool"] == 10  # 1.25 n, as the reference code draws
    with pytest.raises(ValueError, match="pool is only used with normalization='batch'"):
        generate_dataset(8, seed=1, pool=10, progress=False)
