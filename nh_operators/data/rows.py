"""Rows of a dataset, read when asked for: what lets a process hold only its share.

A training process needs, at any time, only the rows of the batches it is about to
train on. :class:`H5Rows` reads those rows from the dataset's HDF5 file (the sensors
``V`` and the labels ``q``, ``p``; nothing else), in one sorted pass over the rows asked
for, at most ``block_rows`` rows at a time: its memory is the answer plus that bounded
block. :class:`MemoryRows` gives the same interface to a dataset already in memory.
:func:`split_indices` is the paper's 80/20 hold-out, shared with
:meth:`~nh_operators.data.Dataset.split_indices`.
"""

import abc
import os
from typing import final

import h5py
import numpy as np

from ._h5 import FORMAT, attrs_of, checksum, generator_of, h5_array, int_attr

__all__ = ["H5Rows", "MemoryRows", "Rows", "open_rows", "split_indices"]

#: Rows read from the file at once (three float64 arrays: 19 MB at 100 sensors).
BLOCK_ROWS = 8192


def split_indices(n, seed, train_fraction=0.8):
    """Random train/validation indices of n samples (the paper's 80/20 hold-out).

    Args:
        n: number of samples.
        seed: permutation seed (a dataset's own seed by default).
        train_fraction: fraction of samples for training, in (0, 1).

    Returns:
        (train, validation): sorted index arrays of round(train_fraction · n) and the
        remaining samples.

    Raises:
        ValueError: if train_fraction is outside (0, 1).

    Example:
        >>> train, val = split_indices(10, seed=0)
        >>> len(train), len(val), sorted([*train, *val]) == list(range(10))
        (8, 2, True)
    """
    if not 0 < train_fraction < 1:
        raise ValueError(f"train_fraction must lie in (0, 1), got {train_fraction}")
    order = np.random.default_rng(seed).permutation(n)
    n_train = round(train_fraction * n)
    return np.sort(order[:n_train]), np.sort(order[n_train:])


class Rows(abc.ABC):
    """Read access to the rows (potentials) of a dataset.

    Attributes:
        t: (M,) query times of the labels.
        seed: the dataset's seed (the default split seed).
        checksum: the dataset's checksum (checkpoints record it).
        generator: the generator that made it, with its ``draw`` version (1 for files
            that predate draw 2; :func:`~nh_operators.data.generate.generator_of`).
        states: whether each row starts from its own (q0, p0); then the V that
            :meth:`read` returns holds the sensors followed by q0 and p0, (k, m + 2).
    """

    t: np.ndarray
    seed: int
    checksum: str | None
    generator: dict
    states: bool = False

    @abc.abstractmethod
    def __len__(self) -> int:
        """Number of rows N."""

    @abc.abstractmethod
    def read(self, index, dtype=np.float64):
        """Rows ``index``, in the order asked for.

        Args:
            index: integer array (k,) of row numbers in [0, N), any order, repeats
                allowed.
            dtype: dtype of the arrays returned (converted block by block).

        Returns:
            (V, q, p): arrays of shape (k, m) (with states (k, m + 2): the network's
            input), (k, M), (k, M).

        Raises:
            IndexError: for a row number outside [0, N).
        """

    def split_indices(self, train_fraction=0.8, seed=None):
        """The dataset's train/validation split (see :func:`split_indices`)."""
        return split_indices(len(self), self.seed if seed is None else seed,
                             train_fraction)

    def _check(self, index):
        index = np.asarray(index, dtype=np.int64).reshape(-1)
        if index.size and (index.min() < 0 or index.max() >= len(self)):
            raise IndexError(f"row numbers must lie in [0, {len(self)}), got "
                             f"[{index.min()}, {index.max()}]")
        return index


@final
class MemoryRows(Rows):
    """:class:`Rows` of a :class:`~nh_operators.data.Dataset` in memory (no copy).

    Args:
        dataset: the dataset.

    Example:
        >>> from nh_operators.data import generate_dataset
        >>> ds = generate_dataset(5, seed=0, progress=False)
        >>> V, q, p = MemoryRows(ds).read([4, 0])
        >>> bool((V[1] == ds.V[0]).all()), q.shape
        (True, (2, 100))
    """

    def __init__(self, dataset):
        self.dataset = dataset
        self.states = getattr(dataset, "q0", None) is not None
        self._branch = dataset.branch_input() if self.states else dataset.V
        self.t = np.asarray(dataset.t)
        self.seed = dataset.seed
        self.checksum = dataset.checksum
        self.generator = dict(getattr(dataset, "generator", None) or {"draw": 1})

    def __len__(self):
        return len(self.dataset)

    def read(self, index, dtype=np.float64):
        index = self._check(index)
        ds = self.dataset
        return tuple(a[index].astype(dtype, copy=False) for a in (self._branch, ds.q, ds.p))


@final
class H5Rows(Rows):
    """:class:`Rows` read from a dataset's HDF5 file on demand.

    The file is opened for each :meth:`read` and closed after it, so an instance holds
    no file handle and no rows between reads.

    Args:
        path: HDF5 file written by :func:`~nh_operators.data.generate_dataset`.
        verify: check the stored SHA-256 checksum once, streaming the file in blocks.
        block_rows: most rows held in memory at once while reading (default 8192).

    Raises:
        FileNotFoundError: if the file is missing.
        ValueError: if it is not an nh-operators dataset or the checksum differs.

    Example:
        >>> rows = H5Rows("standard.h5")  # doctest: +SKIP
        >>> V, q, p = rows.read([7, 3])  # doctest: +SKIP
    """

    NAMES = ("V", "q", "p")

    def __init__(self, path, *, verify=True, block_rows=BLOCK_ROWS):
        self.path = os.fspath(path)
        if not os.path.exists(self.path):
            raise FileNotFoundError(f"no dataset at {self.path!r}")
        if int(block_rows) != block_rows or block_rows < 1:
            raise ValueError(f"block_rows must be a positive integer, got {block_rows}")
        self.block_rows = int(block_rows)
        with h5py.File(self.path, "r") as f:
            fmt = f.attrs.get("format")
            fmt = fmt.decode() if isinstance(fmt, bytes) else fmt
            if fmt != FORMAT:
                raise ValueError(f"{self.path!r} is not an nh-operators dataset "
                                 f"(format {fmt!r})")
            missing = [k for k in ("t", *self.NAMES) if k not in f]
            if missing:
                raise ValueError(f"{self.path!r} lacks the arrays {missing}")
            stored = f.attrs.get("checksum")
            self.checksum = stored.decode() if isinstance(stored, bytes) else stored
            if verify and checksum(f) != self.checksum:
                raise ValueError(f"checksum mismatch in {self.path!r}: the file is "
                                 "corrupted or was modified")
            self.t = np.asarray(h5_array(f, "t")[()])
            self.states = "states" in f.attrs
            self.seed = int_attr(f, "seed")
            self.generator = generator_of(attrs_of(f))
            self._n = h5_array(f, "V").shape[0]

    def __len__(self):
        return self._n

    def read(self, index, dtype=np.float64):
        index = self._check(index)
        order = np.argsort(index, kind="stable")
        wanted = index[order]
        out = []
        names = self.NAMES + (("q0", "p0") if self.states else ())
        with h5py.File(self.path, "r") as f:
            for name in names:
                data = h5_array(f, name)
                rows = np.empty((index.size,) + data.shape[1:], dtype=dtype)
                pos = 0
                while pos < wanted.size:
                    lo = wanted[pos]
                    end = np.searchsorted(wanted, lo + self.block_rows, side="left")
                    block = data[lo:wanted[end - 1] + 1]  # at most block_rows rows
                    rows[order[pos:end]] = block[wanted[pos:end] - lo]
                    pos = end
                out.append(rows)
        if self.states:  # the network's input: sensors, then q0 and p0
            V, q, p, q0, p0 = out
            out = [np.concatenate([V, q0[:, None], p0[:, None]], axis=1), q, p]
        return tuple(out)


def open_rows(data, *, verify=True):
    """:class:`Rows` of a dataset given as a path (read on demand) or a Dataset.

    Args:
        data: path of an HDF5 dataset file, a :class:`~nh_operators.data.Dataset`, or
            a :class:`Rows` (returned as it is).
        verify: check a file's checksum.

    Returns:
        :class:`H5Rows` for a path, :class:`MemoryRows` for a Dataset.

    Raises:
        TypeError: for anything else.
    """
    if isinstance(data, Rows):
        return data
    if isinstance(data, (str, os.PathLike)):
        return H5Rows(data, verify=verify)
    if hasattr(data, "V") and hasattr(data, "q") and hasattr(data, "p"):
        return MemoryRows(data)
    raise TypeError(f"expected a dataset path or a Dataset, got {type(data).__name__}")
