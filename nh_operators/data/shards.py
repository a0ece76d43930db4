"""One process's share of the training data: its slice of every global batch.

:class:`ShardedOperatorData` is the :class:`~nh_operators.OperatorData` that
:func:`nh_operators.train` uses. It holds no dataset: it reads, from a
:class:`~nh_operators.data.Rows` (an HDF5 file or a dataset in memory), the rows that
this rank trains on next, and its share of the validation set.

With N processes (ranks), iteration k of epoch e uses the same global batch as a single
process: rows k·B … (k+1)·B of the epoch's permutation, drawn from
``(shuffle_seed, e)``. Rank r takes the contiguous slice ⌊rL/N⌋ … ⌊(r+1)L/N⌋ of that
batch of L rows (L = B except in an epoch's last batch). Its loss is the mean over its
rows times ``n_r · N / L``, so that the average over the ranks of the gradients (what
DistributedDataParallel computes) is the gradient of the mean over the global batch. A
rank whose slice is empty (a last batch smaller than N) trains on the batch's first row
with weight 0.

Memory: at most ``max_rows`` training rows per rank (by default the rank's rows of a
whole epoch, 1/N of the training set), its 1/N of the validation set, and the reader's
bounded block; the rows of a window are read in one sorted pass over the file.
"""

import numpy as np
import torch

from .operator_data import OperatorData

__all__ = ["ShardedOperatorData", "check_global_batch", "shard_bounds"]


def check_global_batch(batch_size, world_size):
    """Check that the global batch splits evenly over the processes.

    Args:
        batch_size: the global batch (``--batch-size``), potentials per iteration.
        world_size: number of processes N.

    Returns:
        int: the rows of a full batch on each rank, ``batch_size // world_size``.

    Raises:
        ValueError: if N does not divide the batch.

    Example:
        >>> check_global_batch(100, 4)
        25
    """
    if batch_size % world_size:
        lower = batch_size - batch_size % world_size
        raise ValueError(
            f"--batch-size {batch_size} is the global batch and must be divisible by the "
            f"{world_size} processes; choose a multiple of {world_size} such as "
            f"{lower or world_size} or {lower + world_size}")
    return batch_size // world_size


def shard_bounds(rows, rank, world_size):
    """The slice ``[lo, hi)`` of ``rows`` items that ``rank`` of ``world_size`` takes.

    Args:
        rows: number of items L.
        rank: r in [0, N).
        world_size: N.

    Returns:
        (lo, hi) = (⌊rL/N⌋, ⌊(r+1)L/N⌋); the slices of all ranks tile [0, L).

    Example:
        >>> [shard_bounds(7, r, 2) for r in range(2)]
        [(0, 3), (3, 7)]
    """
    return rank * rows // world_size, (rank + 1) * rows // world_size


class ShardedOperatorData(OperatorData):
    """:class:`~nh_operators.OperatorData` of one rank, read from a :class:`Rows`.

    Args:
        rows: a :class:`~nh_operators.data.Rows` (:func:`~nh_operators.data.open_rows`).
        train_fraction: training part of the dataset's random split (default 0.8).
        batch_size: the global batch B; ``dde.Model.train`` must be given the same.
        rank: this process's rank r (default 0).
        world_size: number of processes N (default 1).
        dtype: dtype of the arrays handed to DeepXDE.
        beta: weight of a network's KL term (VaRONet).
        shuffle_seed: seed of the batch order.
        monitor_size: validation samples of DeepXDE's own display (default 100).
        max_rows: most training rows held at once (default: the rank's rows of a whole
            epoch, read in one pass); smaller values read the epoch in several passes.
        split_seed: seed of the train/validation split (default: the dataset's).
        physics: a :class:`~nh_operators.data.PhysicsTerms` for physics-informed
            training (default None); as :class:`~nh_operators.OperatorData`.

    Raises:
        ValueError: if N does not divide B, or a bad rank or max_rows.

    Attributes:
        loss_scale: n_r · N / L of the current batch (1 for a single process).

    Example:
        >>> from nh_operators.data import MemoryRows, generate_dataset
        >>> rows = MemoryRows(generate_dataset(10, seed=0, progress=False))
        >>> data = ShardedOperatorData(rows, batch_size=4, rank=1, world_size=2)
        >>> (V, t), y = data.train_next_batch(4)
        >>> V.shape, t.shape, y.shape, data.loss_scale
        ((2, 100), (100, 1), (2, 100, 2), 1.0)
    """

    def __init__(self, rows, train_fraction=0.8, *, batch_size, rank=0, world_size=1,
                 dtype=np.float32, beta=0.0, shuffle_seed=0, monitor_size=100,
                 max_rows=None, split_seed=None, physics=None):
        check_global_batch(batch_size, world_size)
        if not 0 <= rank < world_size:
            raise ValueError(f"rank must lie in [0, {world_size}), got {rank}")
        if max_rows is not None and not (int(max_rows) == max_rows and max_rows >= 1):
            raise ValueError(f"max_rows must be a positive integer, got {max_rows}")
        train, val = rows.split_indices(train_fraction, split_seed)
        lo, hi = shard_bounds(len(val), rank, world_size)
        V_val, q_val, p_val = rows.read(val[lo:hi], dtype)
        trunk = rows.t[:, None].astype(dtype)
        empty_V = np.empty((0, V_val.shape[1]), dtype)
        super().__init__((empty_V, trunk), np.empty((0, len(trunk), 2), dtype),
                         (V_val, trunk), np.stack([q_val, p_val], axis=-1), beta=beta,
                         shuffle_seed=shuffle_seed, monitor_size=monitor_size,
                         physics=physics)
        self._labelled = None if physics is None else physics.labelled(len(train))
        self.rows, self.train_index, self.dtype = rows, train, dtype
        self.batch_size, self.rank, self.world_size = int(batch_size), rank, world_size
        self.max_rows = max_rows
        self.loss_scale = 1.0
        self._window = None  # (epoch, first step, V, q, p, offsets, meta)

    @property
    def n_train(self):
        return len(self.train_index)

    def _share(self, batch):
        """This rank's part of a global batch: (rows, (L, lo, hi), loss scale)."""
        size = len(batch)
        lo, hi = shard_bounds(size, self.rank, self.world_size)
        if hi == lo:  # a last batch smaller than N: one row with weight 0
            return batch[:1], (size, 0, 1), 0.0
        return batch[lo:hi], (size, lo, hi), (hi - lo) * self.world_size / size

    def _load(self, epoch, step):
        self._window = None  # free the old window before reading the next
        perm = self._permutation(epoch)
        steps, B = self.steps_per_epoch(self.batch_size), self.batch_size
        stop = steps if self.max_rows is None else min(
            steps, step + max(1, self.max_rows // (B // self.world_size)))
        parts, meta = [], []
        for k in range(step, stop):
            part, bounds, scale = self._share(perm[k * B:(k + 1) * B])
            parts.append(part)
            meta.append((*bounds, scale))
        offsets = np.concatenate([[0], np.cumsum([len(p) for p in parts])])
        positions = np.concatenate(parts)
        V, q, p = self.rows.read(self.train_index[positions], self.dtype)
        if self._labelled is not None:  # physics-informed: unlabelled rows have no targets
            q, p = q.copy(), p.copy()
            q[~self._labelled[positions]] = np.nan
            p[~self._labelled[positions]] = np.nan
        window = (epoch, step, stop, V, q, p, offsets, meta)
        self._window = window
        return window

    def _current(self):
        steps = self.steps_per_epoch(self.batch_size)
        epoch, k = divmod(self.cursor, steps)
        w = self._window
        if w is None or w[0] != epoch or not w[1] <= k < w[2]:
            w = self._load(epoch, k)
        return w, k - w[1]

    def train_next_batch(self, batch_size=None):
        if batch_size != self.batch_size:
            raise ValueError(f"this data was built for batch_size={self.batch_size}, "
                             f"got {batch_size!r}")
        (_, _, _, V, q, p, offsets, meta), j = self._current()
        a, b = offsets[j], offsets[j + 1]
        self.loss_scale = meta[j][3]
        self._record = True
        return (V[a:b], self._trunk()), np.stack([q[a:b], p[a:b]], axis=-1)

    def losses_train(self, targets, outputs, loss_fn, inputs, model, aux=None):
        losses = self._losses(targets, outputs, loss_fn, model, inputs)
        if self.world_size > 1:
            losses = [loss * self.loss_scale for loss in losses]
        if self._record:
            self.last_loss = float(sum(loss.detach() for loss in losses))
            self._record = False
        return losses

    def batch_noise(self, like):
        """Standard normal noise for this rank's rows of the current global batch.

        The noise of the whole global batch is drawn and sliced, so the random stream
        (and the samples each row gets) is that of a single process; VaRONet takes it
        through its ``noise`` attribute in a distributed run.

        Args:
            like: tensor (n_r, ...) of this rank's rows (dtype and device are taken).

        Returns:
            Tensor of the shape of ``like``.
        """
        (_, _, _, _, _, _, _, meta), j = self._current()
        size, lo, hi, _ = meta[j]
        noise = torch.randn((size, *like.shape[1:]), dtype=like.dtype, device=like.device)
        return noise[lo:hi]

    def memory_bytes(self):
        """Bytes of rows this object holds now: its training window and validation share."""
        held = sum(a.nbytes for a in (self.test_x[0], self.test_y))
        if self._window is not None:
            held += sum(a.nbytes for a in self._window[3:6])
        return held

