"""HDF5 storage of datasets: streamed, resumable, atomic writes and checksummed reads."""

import hashlib
import json
import os

import h5py
import numpy as np
from tqdm.auto import tqdm

from .._constants import SENSORS, TIMES

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
FIXED = ("x", "t")
_JSON_ATTRS = ("generator", "dropped")
_BLOCK = 65536


def checksum(h5file):
    """SHA-256 over every array's name, shape, dtype and bytes, read in blocks."""
    digest = hashlib.sha256()
    for name in FIXED + tuple(ROWS):
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


def _matches(f, attrs):
    stored = _get_attrs(f)
    return all(stored.get(k) == v for k, v in attrs.items() if k != "version")


def write_streamed(path, n, attrs, source, *, chunk, progress, resume):
    """Write n samples from ``source.take`` to ``path`` through ``path + '.partial'``.

    After every chunk the partial file records the rows written, the drop counts and
    the generator state, so an interrupted run continues where it stopped.
    """
    path = os.fspath(path)
    partial = path + ".partial"
    rng = source.space.rng
    done = 0
    drops = {}
    mode = "w"
    if resume and os.path.exists(partial):
        try:
            with h5py.File(partial, "r") as f:
                if _matches(f, attrs):
                    done = int(f.attrs["rows_done"])
                    drops = json.loads(f.attrs["dropped"])
                    rng.bit_generator.state = json.loads(f.attrs["rng_state"])
                    mode = "r+"
        except (OSError, KeyError, ValueError):
            mode = "w"  # unreadable or foreign partial file: start again
    if mode == "w":
        with h5py.File(partial, "w") as f:
            for name, (shape, dtype) in ROWS.items():
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
            for name in ROWS:
                f[name][done : done + m] = arrays[name]
            done += m
            f.attrs["rows_done"] = done
            f.attrs["dropped"] = json.dumps(drops, sort_keys=True)
            f.attrs["rng_state"] = json.dumps(rng.bit_generator.state)
            f.flush()
            bar.update(m)
            bar.set_postfix(dropped=sum(drops.values()))
        for key in ("rows_done", "rng_state"):
            del f.attrs[key]
        f.attrs["dropped"] = json.dumps(drops, sort_keys=True)
        f.attrs["n_dropped"] = int(sum(drops.values()))
        f.attrs["checksum"] = checksum(f)
    os.replace(partial, path)


def read_dataset(path, *, verify=True):
    """Read all arrays and attributes; check the format and (optionally) the checksum."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"no dataset at {path!r}")
    with h5py.File(path, "r") as f:
        attrs = _get_attrs(f)
        if attrs.get("format") != FORMAT:
            raise ValueError(f"{path!r} is not an nh-operators dataset (format {attrs.get('format')!r})")
        missing = [k for k in FIXED + tuple(ROWS) if k not in f]
        if missing:
            raise ValueError(f"{path!r} lacks the arrays {missing}")
        if verify:
            actual = checksum(f)
            if actual != attrs.get("checksum"):
                raise ValueError(
                    f"checksum mismatch in {path!r}: stored {attrs.get('checksum')}, computed "
                    f"{actual}; the file is corrupted or was modified"
                )
        arrays = {k: f[k][()] for k in FIXED + tuple(ROWS)}
    return arrays, attrs
