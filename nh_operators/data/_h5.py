"""HDF5 storage of datasets: streamed, resumable, atomic writes and checksummed reads."""

import hashlib
import json
import os
import warnings
from collections.abc import Mapping
from typing import Any, cast

import h5py
import numpy as np
from tqdm.auto import tqdm

from .._constants import SENSORS, TIMES
from ._lock import exclusive_lock

FORMAT = "nh-operators-dataset/1"
#: Per-sample arrays (leading axis N) and their trailing shapes and dtypes.
ROWS = {
    "V": ((100,), np.float64),
    "q": ((100,), np.float64),
    "p": ((100,), np.float64),
    "n_grf": ((), np.int8),
    "control_q": ((9,), np.float64),
    "control_V": ((9,), np.float64),
    "length_scale": ((), np.float64),
}
#: Per-sample arrays of a dataset with starting states (attribute ``states``).
STATE_ROWS = {
    "q0": ((), np.float64),
    "p0": ((), np.float64),
    "near_separatrix": ((), np.int8),
}
FIXED = ("x", "t")
_JSON_ATTRS = ("generator", "dropped", "states")


def _rows(states):
    """The per-sample arrays of a file: with ``states`` (its attribute), the states too."""
    return {**ROWS, **STATE_ROWS} if states else ROWS


def h5_array(group: h5py.Group, name: str) -> h5py.Dataset:
    """The array ``name`` of an open HDF5 file (h5py types ``f[name]`` as any HDF5 object).

    Args:
        group: an open ``h5py.File`` or group.
        name: the array's name.

    Returns:
        The ``h5py.Dataset`` (nothing is read).

    Example:
        >>> import io
        >>> with h5py.File(io.BytesIO(), "w") as f:
        ...     _ = f.create_dataset("t", data=[1.0, 2.0])
        ...     h5_array(f, "t").shape
        (2,)
    """
    return cast(h5py.Dataset, group[name])


def int_attr(group: h5py.Group, key: str) -> int:
    """The integer attribute ``key`` of an open HDF5 file, as a Python int.

    Args:
        group: an open ``h5py.File`` or group.
        key: the attribute's name.

    Returns:
        ``int(group.attrs[key])``.

    Raises:
        KeyError: if the attribute is missing.

    Example:
        >>> import io
        >>> with h5py.File(io.BytesIO(), "w") as f:
        ...     f.attrs["seed"] = 7
        ...     int_attr(f, "seed")
        7
    """
    return int(cast(int, group.attrs[key]))


_BLOCK = 65536


def checksum(h5file):
    """SHA-256 over every array's name, shape, dtype and bytes, read in blocks.

    Only the arrays enter it: no attribute (package version, generator parameters, drops),
    so a dataset keeps its checksum across package versions as long as its bytes are the
    same. From draw 2 (``generator["draw"]``) the generator's Gaussian draw runs in plain
    loops, so the same preset, seed and size give the same bytes, and this checksum, on
    any CPU (``tests/data/test_checksum.py`` pins one); files of draw 1 (no ``draw``
    key) went through ``np.linalg.cholesky``, whose last bits depend on the CPU.
    """
    digest = hashlib.sha256()
    for name in FIXED + tuple(_rows("states" in h5file.attrs)):
        data = h5file[name]
        digest.update(f"{name}{data.shape}{data.dtype.str}".encode())
        if data.ndim == 1 and name in FIXED:
            digest.update(np.ascontiguousarray(data[()]).tobytes())
            continue
        for start in range(0, data.shape[0], _BLOCK):
            digest.update(np.ascontiguousarray(data[start : start + _BLOCK]).tobytes())
    return "sha256:" + digest.hexdigest()


def _set_attrs(f, attrs):
    for key, value in attrs.items():
        f.attrs[key] = json.dumps(value, sort_keys=True) if key in _JSON_ATTRS else value


def _get_attrs(f):
    out = {}
    for key, value in f.attrs.items():
        if isinstance(value, bytes):
            value = value.decode()
        if key in _JSON_ATTRS:
            value = json.loads(value)
        elif isinstance(value, np.generic):
            value = value.item()
        out[key] = value
    return out


def attrs_of(f: h5py.File) -> dict[str, Any]:
    """The attributes of an open dataset file, JSON ones decoded.

    Args:
        f: an open dataset file.

    Returns:
        dict of the attributes (``generator``, ``dropped`` and ``states`` as dicts).
    """
    return _get_attrs(f)


def generator_of(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """The generator that made a dataset, from its attributes, with its draw version.

    Files written before draw 2 record no ``draw``: they were made by draw 1 (BLAS
    Cholesky, whose last bits depend on the CPU), and the result says so.

    Args:
        attrs: a dataset's attributes (:attr:`Dataset.attrs`, ``dataset_attrs(path)``).

    Returns:
        The ``generator`` attribute (parameters) with ``draw`` (1 when absent) and
        ``package``, the nh-operators version that wrote the file (None if unrecorded).

    Example:
        >>> generator_of({"generator": {"omega": 0.05}, "version": "0.1.0"})
        {'omega': 0.05, 'draw': 1, 'package': '0.1.0'}
    """
    out = dict(attrs.get("generator") or {})
    out.setdefault("draw", 1)
    out["package"] = attrs.get("version")
    return out


def _matches(f, attrs):
    stored = _get_attrs(f)
    return all(stored.get(k) == v for k, v in attrs.items() if k != "version")


def _chunk_digest(f, start, end):
    """SHA-256 of rows [start, end) of every per-sample array (what a resume keeps)."""
    digest = hashlib.sha256()
    for name in _rows("states" in f.attrs):
        digest.update(np.ascontiguousarray(f[name][start:end]).tobytes())
    return digest.hexdigest()


def _verified_prefix(f, path):
    """Rows, drops and generator state after the last chunk whose checksum still holds.

    Returns None when no chunk survives (start again). Warns for a chunk that fails.
    """
    chunks = json.loads(f.attrs.get("chunks", "[]"))
    kept = None
    start = 0
    for chunk in chunks:
        if _chunk_digest(f, start, chunk["end"]) != chunk["sha256"]:
            warnings.warn(f"{path}: rows {start}-{chunk['end'] - 1} no longer match the "
                          "checksum recorded when they were written; labelling them again "
                          f"from row {start}", UserWarning, stacklevel=4)
            break
        kept, start = chunk, chunk["end"]
    return kept, chunks[:chunks.index(kept) + 1] if kept else []


def write_streamed(path, n, attrs, source, *, chunk, progress, resume):
    """Write n samples from ``source.take`` to ``path`` through ``path + '.partial'``.

    A lock file (``path + '.lock'``) is taken before anything is opened, so a second
    run on the same path fails at once and leaves the first untouched. After every chunk
    the partial file records the rows written, the drop counts, the generator state and
    a SHA-256 of the chunk's rows; a resumed run checks every kept chunk against it and
    labels again from the first chunk that no longer matches (with a warning).
    """
    path = os.fspath(path)
    partial = path + ".partial"
    with exclusive_lock(path + ".lock", what=path):
        _write_locked(path, partial, n, attrs, source, chunk, progress, resume)


def _write_locked(path, partial, n, attrs, source, chunk, progress, resume):
    start_state = json.loads(json.dumps(source.state()))
    done, drops, chunks = 0, {}, []
    mode = "w"
    if resume and os.path.exists(partial):
        try:
            with h5py.File(partial, "r+") as f:
                if _matches(f, attrs) and int_attr(f, "rows_done") > 0:
                    kept, chunks = _verified_prefix(f, partial)
                    if kept is not None:
                        done, drops = kept["end"], kept["dropped"]
                        source.set_state(kept["state"])
                        mode = "r+"
        except (OSError, KeyError, ValueError):
            mode = "w"  # unreadable or foreign partial file: start again
    if mode == "w":
        source.set_state(start_state)
        with h5py.File(partial, "w") as f:
            for name, (shape, dtype) in _rows(attrs.get("states")).items():
                f.create_dataset(name, shape=(n,) + shape, dtype=dtype, track_times=False,
                                 chunks=(min(n, 4096),) + shape)
            f.create_dataset("x", data=np.array(SENSORS), track_times=False)
            f.create_dataset("t", data=np.array(TIMES), track_times=False)
            _set_attrs(f, attrs)
    with h5py.File(partial, "r+") as f, tqdm(
        total=n, initial=done, disable=not progress, unit="potential", desc="labels"
    ) as bar:
        while done < n:
            m = min(chunk, n - done)
            arrays, drops = source.take(m, drops)
            for name in _rows(attrs.get("states")):
                h5_array(f, name)[done : done + m] = arrays[name]
            chunks.append({"end": done + m, "sha256": _chunk_digest(f, done, done + m),
                           "dropped": dict(drops), "state": source.state()})
            done += m
            f.attrs["rows_done"] = done
            f.attrs["dropped"] = json.dumps(drops, sort_keys=True)
            f.attrs["chunks"] = json.dumps(chunks)
            f.flush()
            bar.update(m)
            bar.set_postfix(dropped=sum(drops.values()))
        for key in ("rows_done", "chunks"):
            del f.attrs[key]
        f.attrs["dropped"] = json.dumps(drops, sort_keys=True)
        f.attrs["n_dropped"] = int(sum(drops.values()))
        f.attrs["checksum"] = checksum(f)
    os.replace(partial, path)


def partial_progress(path):
    """(rows written, rows asked) of an interrupted run's ``path + '.partial'``, or None."""
    try:
        with h5py.File(os.fspath(path) + ".partial", "r") as f:
            return int(f.attrs.get("rows_done", 0)), int(f.attrs.get("size", 0))
    except (OSError, KeyError, ValueError):
        return None


def open_h5(path):
    """Open a dataset file for reading, with a clear error for everything but a dataset.

    Raises:
        FileNotFoundError: if there is no file.
        ValueError: for a directory, a file HDF5 cannot read (truncated, still being
            written, not HDF5), or an HDF5 file that is not an nh-operators dataset.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"no dataset at {path!r}")
    if os.path.isdir(path):
        raise ValueError(f"{path!r} is a directory; give the dataset's .h5 file")
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise ValueError(f"{path!r} is not a readable HDF5 file ({err}); it may be truncated "
                         "or still being written: generate it again") from None
    fmt = f.attrs.get("format")
    fmt = fmt.decode() if isinstance(fmt, bytes) else fmt
    if fmt != FORMAT:
        f.close()
        raise ValueError(f"{path!r} is not an nh-operators dataset (format {fmt!r})")
    return f


def dataset_attrs(path):
    """A dataset file's attributes (size, seed, generator, checksum, ...), read cheaply.

    Raises:
        FileNotFoundError, ValueError: as :func:`open_h5`.
    """
    with open_h5(path) as f:
        return _get_attrs(f)


def read_dataset(path, *, verify=True):
    """Read all arrays and attributes; check the format and (optionally) the checksum."""
    path = os.fspath(path)
    with open_h5(path) as f:
        attrs = _get_attrs(f)
        names = FIXED + tuple(_rows(attrs.get("states")))
        missing = [k for k in names if k not in f]
        if missing:
            raise ValueError(f"{path!r} lacks the arrays {missing}")
        if verify:
            actual = checksum(f)
            if actual != attrs.get("checksum"):
                raise ValueError(
                    f"checksum mismatch in {path!r}: stored {attrs.get('checksum')}, computed "
                    f"{actual}; the file is corrupted or was modified"
                )
        arrays = {k: h5_array(f, k)[()] for k in names}
    return arrays, attrs
