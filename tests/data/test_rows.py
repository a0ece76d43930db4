"""Rows read on demand from HDF5, and one rank's share of every global batch."""

import itertools

import h5py
import numpy as np
import pytest
import torch
from model_helpers import TINY

import nh_operators as nh
from nh_operators.data import (
    H5Rows,
    MemoryRows,
    ShardedOperatorData,
    check_global_batch,
    generate_dataset,
    open_rows,
    shard_bounds,
    split_indices,
)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rows")
    ds = generate_dataset(56, seed=3, path=folder / "d.h5", progress=False)
    return ds, folder / "d.h5"


def test_h5_rows_read_any_order_with_repeats_in_bounded_blocks(files):
    ds, path = files
    rows = H5Rows(path, block_rows=7)
    assert len(rows) == 56 and rows.checksum == ds.checksum and rows.seed == 3
    index = np.random.default_rng(0).integers(0, 56, 40)
    index[:3] = [55, 0, 55]
    V, q, p = rows.read(index)
    np.testing.assert_array_equal(V, ds.V[index])
    np.testing.assert_array_equal(q, ds.q[index])
    np.testing.assert_array_equal(p, ds.p[index])
    V32, _, _ = rows.read(index, np.float32)
    assert V32.dtype == np.float32
    np.testing.assert_array_equal(V32, ds.V[index].astype(np.float32))
    assert [a.shape for a in rows.read([])] == [(0, 100)] * 3
    with pytest.raises(IndexError, match=r"row numbers must lie in \[0, 56\), got \[0, 56\]"):
        rows.read([0, 56])
    mem = MemoryRows(ds)
    for a, b in zip(mem.read(index), (V, q, p)):
        np.testing.assert_array_equal(a, b)
    assert isinstance(open_rows(path), H5Rows) and isinstance(open_rows(ds), MemoryRows)


def test_h5_rows_never_hold_more_than_a_block(files, monkeypatch):
    _, path = files
    sizes = []
    real = h5py.Dataset.__getitem__

    def spy(self, key):
        out = real(self, key)
        sizes.append(len(out))
        return out

    monkeypatch.setattr(h5py.Dataset, "__getitem__", spy)
    rows = H5Rows(path, verify=False, block_rows=5)
    sizes.clear()
    rows.read(np.arange(0, 56, 2))
    # rows 0, 2, ..., 54: nine blocks of 5 rows (three wanted in each), then row 54 alone,
    # for each of V, q and p
    assert sizes == ([5] * 9 + [1]) * 3


def test_h5_rows_refuse_a_modified_or_foreign_file(files, tmp_path):
    _, path = files
    bad = tmp_path / "bad.h5"
    bad.write_bytes(path.read_bytes())
    with h5py.File(bad, "r+") as f:
        f["q"][3, 4] += 1.0
    with pytest.raises(ValueError, match="checksum mismatch"):
        H5Rows(bad)
    H5Rows(bad, verify=False)  # opt-out, as load_dataset(verify=False)
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f.attrs["format"] = "something/1"
    with pytest.raises(ValueError, match="not an nh-operators dataset"):
        H5Rows(tmp_path / "other.h5")
    with pytest.raises(FileNotFoundError):
        H5Rows(tmp_path / "missing.h5")


def test_split_is_the_datasets_split(files):
    ds, path = files
    for a, b in zip(ds.split_indices(0.8), H5Rows(path).split_indices(0.8)):
        np.testing.assert_array_equal(a, b)
    train, val = split_indices(56, 3, 0.8)
    assert len(train) == 45 and len(val) == 11


def test_global_batch_must_divide_and_shards_tile():
    assert check_global_batch(100, 4) == 25
    with pytest.raises(ValueError, match=r"--batch-size 15 is the global batch and must "
                       r"be divisible by the 2 processes; choose a multiple of 2 such as "
                       r"14 or 16"):
        check_global_batch(15, 2)
    for n in (0, 1, 5, 7, 100):
        bounds = [shard_bounds(n, r, 3) for r in range(3)]
        assert bounds[0][0] == 0 and bounds[-1][1] == n
        assert all(a[1] == b[0] for a, b in itertools.pairwise(bounds))


def _batches(data, epochs):
    out = []
    for _ in range(epochs * data.steps_per_epoch(data.batch_size)):
        (V, _), y = data.train_next_batch(data.batch_size)
        out.append((V, y, data.loss_scale))
        data.advance()
    return out


@pytest.mark.parametrize("batch, scales", [(10, (0.8, 1.2)), (4, (0.0, 2.0))])
def test_ranks_split_every_global_batch_of_the_single_process(files, batch, scales):
    ds, path = files
    single = ds.to_deepxde(dtype=np.float64, shuffle_seed=5)
    reference = []
    for _ in range(2 * single.steps_per_epoch(batch)):
        (V, _), y = single.train_next_batch(batch)
        reference.append((V, y))
        single.advance()
    rows = H5Rows(path)
    ranks = [_batches(ShardedOperatorData(rows, batch_size=batch, rank=r, world_size=2,
                                          dtype=np.float64, shuffle_seed=5), 2)
             for r in range(2)]
    windowed = _batches(ShardedOperatorData(rows, batch_size=batch, rank=1, world_size=2,
                                            dtype=np.float64, shuffle_seed=5,
                                            max_rows=3), 2)
    for k, (V, y) in enumerate(reference):
        (V0, y0, s0), (V1, y1, s1) = ranks[0][k], ranks[1][k]
        if s0 == 0.0:  # a last batch of one row: rank 0 trains on it with weight 0
            np.testing.assert_array_equal(V0, V)
            np.testing.assert_array_equal(V1, V)
            assert s1 == 2.0
        else:
            np.testing.assert_array_equal(np.concatenate([V0, V1]), V)
            np.testing.assert_array_equal(np.concatenate([y0, y1]), y)
            assert (s0, s1) == (2 * len(V0) / len(V), 2 * len(V1) / len(V))
        np.testing.assert_array_equal(windowed[k][0], V1)
    last = (ranks[0][single.steps_per_epoch(batch) - 1][2],
            ranks[1][single.steps_per_epoch(batch) - 1][2])
    assert last == scales  # 45 training rows: a last batch of 5 (2 + 3 rows) or 1


def test_each_rank_holds_its_share_of_the_rows(files):
    _, path = files
    rows = H5Rows(path)
    one = ShardedOperatorData(rows, batch_size=10, dtype=np.float64)
    half = ShardedOperatorData(rows, batch_size=10, rank=1, world_size=2,
                               dtype=np.float64)
    one.train_next_batch(10), half.train_next_batch(10)
    assert one.memory_bytes() == 56 * 300 * 8
    assert half.memory_bytes() == (23 + 6) * 300 * 8  # 23 of 45 training, 6 of 11 val
    with pytest.raises(ValueError, match="built for batch_size=10"):
        half.train_next_batch(20)


def test_ranks_average_to_the_single_process_gradient_with_kl_and_noise(files):
    """What DDP computes (the mean of the ranks' gradients) is the gradient of the
    global batch, VaRONet's KL column and reparameterisation noise included."""
    ds, _ = files
    rows = MemoryRows(ds)
    torch.manual_seed(0)
    net = nh.build_model("varonet", "cpu", **TINY["varonet"]).double()

    class Model:
        pass

    Model.net = net

    def gradient(data, noise, cursor):
        data.cursor = cursor
        (V, t), y = data.train_next_batch(10)
        net.noise = noise
        torch.manual_seed(11)
        out = net((torch.as_tensor(V), torch.as_tensor(t)))
        losses = data.losses_train(torch.as_tensor(y), out,
                                   torch.nn.functional.mse_loss, None, Model)
        net.zero_grad()
        sum(losses).backward()
        return torch.cat([p.grad.reshape(-1) for p in net.parameters()]), data.last_loss

    kw = {"batch_size": 10, "dtype": np.float64, "beta": 0.3, "shuffle_seed": 2}
    single = ShardedOperatorData(rows, **kw)
    ranks = [ShardedOperatorData(rows, rank=r, world_size=2, **kw) for r in range(2)]
    for cursor in (0, 4):  # a full batch, and the last batch of 5 rows (2 + 3)
        g, loss = gradient(single, None, cursor)
        parts = [gradient(d, d.batch_noise, cursor) for d in ranks]
        mean = (parts[0][0] + parts[1][0]) / 2
        assert torch.allclose(mean, g, rtol=0, atol=1e-13 * g.abs().max().item())
        assert (parts[0][1] + parts[1][1]) / 2 == pytest.approx(loss, rel=1e-13)
    net.noise = None
