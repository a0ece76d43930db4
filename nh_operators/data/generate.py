"""Datasets of random bounded potentials with exact trajectory labels.

:func:`generate_dataset` draws potentials from :class:`BoundedPotentialSpace`, labels
them with :func:`reference_solve` on the exact B-spline curve, drops and counts invalid
samples, tops up to exactly n, and streams chunks to an HDF5 file (see :mod:`._h5`).
"""

import os
from collections.abc import Mapping
from typing import Any, Literal

import numpy as np

from .._constants import V0
from .._dataset_presets import DATASET_PRESETS
from .._version import __version__
from ..potentials import BoundedPotential, BoundedPotentialSpace
from ..potentials.gaussian import DRAW_VERSION, DRAW_VERSIONS
from ._h5 import generator_of, read_dataset, write_streamed
from .labels import ENERGY_TOL, LABEL_RTOL, StateStream, SampleSource, label_potentials

__all__ = ["DATASET_PRESETS", "Dataset", "check_output_path", "checksum_mismatch",
           "describe_draw", "generate_dataset", "generator_of", "label_potentials",
           "load_dataset", "preset_kwargs"]


def preset_kwargs(name: str) -> dict[str, Any]:
    """``generate_dataset`` keyword arguments of a preset (all but size and seed).

    Example:
        >>> preset_kwargs("paper-test")
        {'normalization': 'batch', 'pool': 6250, 'skip': 1000}
    """
    if name not in DATASET_PRESETS:
        raise ValueError(f"unknown preset {name!r}; choose from {sorted(DATASET_PRESETS)}")
    return {k: v for k, v in DATASET_PRESETS[name].items() if k not in ("size", "seed")}


def describe_draw(draw: int) -> str:
    """One line on a draw version: what computed the Gaussian values.

    Example:
        >>> describe_draw(1)
        'draw 1 (np.exp and BLAS Cholesky: last bits depend on the CPU)'
    """
    return f"draw {draw} ({DRAW_VERSIONS.get(draw, 'unknown to this version')})"


def checksum_mismatch(what: str, recorded: str, dataset: Any,
                      recorded_draw: int | None = None) -> str:
    """The message for a dataset whose checksum is not the one a record expects.

    It names the draw that made the recorded dataset (``recorded_draw``; a record
    without one predates draw 2, so draw 1), the draw that made ``dataset`` and the
    draw this version uses, and what to do about it.

    Args:
        what: what the record is, e.g. ``"the dataset phaseonet-paper was calibrated on"``.
        recorded: the checksum the record holds.
        dataset: the dataset at hand (a :class:`Dataset`).
        recorded_draw: the draw version the record names, or None if it names none.

    Returns:
        The message (several sentences).
    """
    ours = generator_of(dataset.attrs)
    then = 1 if recorded_draw is None else int(recorded_draw)
    lines = [f"this is not {what}: checksum {dataset.checksum}, recorded {recorded}.",
             f"The recorded dataset was made by {describe_draw(then)}"
             + (" (the record names no draw: it predates draw 2)."
                if recorded_draw is None else "."),
             f"This file was made by {describe_draw(ours['draw'])} with nh-operators "
             f"{ours['package']}; this version ({__version__}) draws with draw "
             f"{DRAW_VERSION}."]
    if then != ours["draw"]:
        lines.append("Another draw gives other last bits (up to about 1e-13) of the "
                     "same potentials, so another checksum: use the record's file, or "
                     "redo what the record measured on this one.")
    elif then == 1:
        lines.append("Draw 1's bits depend on the CPU's BLAS kernel: the same command on "
                     "another machine gives another checksum; regenerating with this "
                     f"version (draw {DRAW_VERSION}) gives the same bytes on any CPU.")
    else:
        lines.append("Same draw: the file was made with other parameters, seed or size, "
                     "or was modified.")
    return " ".join(lines)


class Dataset:
    """Potentials at the sensors, exact labels, and what rebuilds each true potential.

    Attributes:
        V: (N, 100) potential at :data:`SENSORS` (``x``).
        x: (100,) sensor positions.
        t: (100,) query times.
        q, p: (N, 100) exact trajectory at ``t``.
        n_grf: (N,) number of interior control points.
        control_q, control_V: (N, 9) control points with the ends, NaN-padded.
        length_scale: (N,) GRF length scale of each draw.
        q0, p0: (N,) starting states, or None for the paper's rest at q = 0.
        near_separatrix: (N,) 1 where the state was drawn near a separatrix, or None.
        attrs: dict of metadata (generator parameters, seed, version, checksum, drops).
    """

    def __init__(self, arrays: Mapping[str, np.ndarray], attrs: Mapping[str, Any]):
        self.V = arrays["V"]
        self.x = arrays["x"]
        self.t = arrays["t"]
        self.q = arrays["q"]
        self.p = arrays["p"]
        self.n_grf = arrays["n_grf"]
        self.control_q = arrays["control_q"]
        self.control_V = arrays["control_V"]
        self.length_scale = arrays["length_scale"]
        self.q0 = arrays.get("q0")
        self.p0 = arrays.get("p0")
        self.near_separatrix = arrays.get("near_separatrix")
        self.attrs = dict(attrs)

    def __len__(self) -> int:
        return self.V.shape[0]

    @property
    def seed(self) -> int:
        return int(self.attrs["seed"])

    @property
    def generator(self) -> dict[str, Any]:
        """The generator that made it (:func:`generator_of`): its parameters, ``draw``
        (the Gaussian draw's version; 1 for files that predate draw 2) and ``package``
        (the nh-operators version that wrote it)."""
        return generator_of(self.attrs)

    @property
    def checksum(self) -> str:
        """The file's SHA-256 checksum, or for a dataset never written, a SHA-256 of its
        arrays (V, t, q, p); checkpoints record it to refuse resuming on other data."""
        if "checksum" in self.attrs:
            return self.attrs["checksum"]
        import hashlib

        digest = hashlib.sha256()
        for array in (self.V, self.t, self.q, self.p):
            digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
        return "arrays-sha256:" + digest.hexdigest()

    def potential(self, i):
        """The exact true potential of sample i (an object with ``.V`` and ``.dV``)."""
        return BoundedPotential(self.control_q[i], self.control_V[i])

    def potentials(self):
        """All true potentials as one batched :class:`BoundedPotential`."""
        return BoundedPotential(self.control_q, self.control_V)

    def split_indices(self, train_fraction: float = 0.8, seed: int | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
        """Random train/validation indices (the paper's 80/20 hold-out).

        Args:
            train_fraction: fraction of samples for training, in (0, 1).
            seed: permutation seed; defaults to the dataset's own seed.

        Returns:
            (train, validation) index arrays.
        """
        from .rows import split_indices

        return split_indices(len(self), self.seed if seed is None else seed,
                             train_fraction)

    def to_deepxde(self, train_fraction=0.8, seed=None, dtype=np.float32, **kwargs):
        """DeepXDE training data of this dataset: an :class:`~nh_operators.OperatorData`.

        Branch input V (N, 100) (with states: V, q0, p0 side by side, (N, 102)), trunk
        input t as (100, 1), targets stack(q, p) of shape (N, 100, 2); the validation
        part is DeepXDE's "test" set. ``OperatorData`` is a
        ``deepxde.data.TripleCartesianProd`` with reproducible batches, an optional
        KL term and batched validation.

        Args:
            train_fraction: training fraction of the random split (default 0.8).
            seed: split seed (default: the dataset's seed).
            dtype: array dtype handed to DeepXDE (networks train in float32).
            **kwargs: passed to :class:`~nh_operators.OperatorData` (``beta``,
                ``shuffle_seed``, ``monitor_size``).

        Returns:
            OperatorData
        """
        from .operator_data import OperatorData

        train, val = self.split_indices(train_fraction, seed)
        y = np.stack([self.q, self.p], axis=-1).astype(dtype)
        trunk = self.t[:, None].astype(dtype)
        branch = self.branch_input().astype(dtype)
        return OperatorData((branch[train], trunk), y[train], (branch[val], trunk), y[val],
                            **kwargs)

    def branch_input(self) -> np.ndarray:
        """What a network sees of each sample: V (N, 100), or with states V, q0 and p0
        side by side (N, 102)."""
        q0, p0 = self.q0, self.p0
        if q0 is None:
            return self.V
        assert p0 is not None  # stored together with q0
        return np.concatenate([self.V, q0[:, None], p0[:, None]], axis=1)


def generate_dataset(n: int, seed: int, path: str | os.PathLike[str] | None = None, *,
                     chunk: int = 2000, progress: bool = True, resume: bool = True,
                     force: bool = False, skip: int = 0, rtol: float = LABEL_RTOL,
                     energy_tol: float = ENERGY_TOL, states: Literal["energy"] | None = None,
                     separatrix_share: float = 0.25, **space_kwargs: Any) -> Dataset:
    """Generate n potentials with exact labels on :data:`SENSORS` / :data:`TIMES`.

    Potentials are drawn one after another from ``BoundedPotentialSpace(seed,
    **space_kwargs)``; invalid samples (non-finite, leaving [0, 1], energy drift above
    ``energy_tol``) are dropped and counted, and drawing continues until exactly n are
    kept, so the dataset is the first n valid draws of the stream: the same seed and
    parameters give the same arrays whatever the chunk size.

    With ``path``, chunks stream to ``path + ".partial"`` (memory stays at a few
    chunks), which is renamed to ``path`` when complete; an interrupted run resumes from
    the partial file when ``resume`` is true and its parameters match, after checking
    every kept chunk against the checksum recorded when it was written. A lock
    (``path + ".lock"``) keeps two runs from writing the same path.

    Args:
        n: number of samples (≥ 1).
        seed: int seed of the generator.
        path: optional HDF5 output path.
        chunk: samples labelled per batch.
        progress: show a tqdm progress bar.
        resume: continue a matching ``.partial`` file.
        force: replace a finished file at ``path`` (otherwise that is an error).
        rtol: tolerance of the reference solve.
        energy_tol: largest accepted energy error.
        skip: valid samples drawn and discarded before the n kept (the paper's test set
            is the last 4,000 of 5,000: ``skip=1000``).
        states: ``None`` (the paper's start at rest at q = 0) or ``"energy"``: each
            potential gets its own bounded starting state (q0, p0), stratified by
            energy (:func:`~nh_operators.solvers.energy_states`), stored as ``q0``,
            ``p0`` and ``near_separatrix``; the labels start there. The attribute
            ``states`` records the distribution.
        separatrix_share: with ``states="energy"``, the share of draws placed near a
            separatrix (where V has an interior maximum).
        **space_kwargs: generator parameters (``n_grf``, ``length_scale``, ``omega``,
            ``normalization`` (``"batch"``: the reference code's distribution; its
            ``pool`` defaults to 1.25 (n + skip) candidates, as the code draws),
            ``margin``).

    Returns:
        :class:`Dataset` (loaded from ``path`` when given).

    Raises:
        ValueError: for n < 1, chunk < 1, a seed that is not a non-negative integer, a
            directory as ``path``, or bad generator parameters.
        FileExistsError: if ``path`` holds a finished file and ``force`` is false, or
            another process is writing ``path``.
        PermissionError: if the folder of ``path`` is not writable.

    Example:
        >>> ds = generate_dataset(8, seed=0, progress=False)
        >>> ds.V.shape, ds.q.shape
        ((8, 100), (8, 100))
    """
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n}")
    if int(seed) != seed or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed}")
    if int(chunk) != chunk or chunk < 1:
        raise ValueError(f"chunk must be a positive integer, got {chunk}")
    n, seed, chunk = int(n), int(seed), int(chunk)
    if path is not None:
        check_output_path(path, force=force)
    if int(skip) != skip or skip < 0:
        raise ValueError(f"skip must be a non-negative integer, got {skip}")
    skip = int(skip)
    if space_kwargs.get("normalization") == "batch" and space_kwargs.get("pool") is None:
        space_kwargs["pool"] = int(np.ceil(1.25 * (n + skip)))
    space = BoundedPotentialSpace(np.random.default_rng(seed), **space_kwargs)
    attrs = {
        "format": "nh-operators-dataset/1",
        "seed": seed,
        "size": n,
        "generator": space.params(),
        "label_rtol": rtol,
        "energy_tol": energy_tol,
        "V0": V0,
        "version": __version__,
    }
    if skip:
        attrs["skip"] = skip
    stream = None
    if states is not None:
        if states != "energy":
            raise ValueError(f"states must be None or 'energy', got {states!r}")
        stream = StateStream(seed, separatrix_share)
        attrs["states"] = stream.params()
    source = SampleSource(space, rtol, energy_tol, skip, stream)
    if path is None:
        arrays, drops = source.take(n)
        attrs["dropped"] = drops
        attrs["n_dropped"] = int(sum(drops.values()))
        return Dataset(arrays, attrs)
    write_streamed(path, n, attrs, source, chunk=chunk, progress=progress, resume=resume)
    return load_dataset(path)


def check_output_path(path, *, force=False):
    """Refuse, before any work, an output path that cannot or should not be written.

    Args:
        path: the dataset file to be written.
        force: allow replacing a finished file.

    Raises:
        ValueError: if ``path`` is a directory.
        FileExistsError: if a finished file is there and ``force`` is false.
        FileNotFoundError: if its folder does not exist.
        PermissionError: if its folder is not writable.
    """
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise ValueError(f"{path!r} is a directory; give a file name such as "
                         f"{os.path.join(path, 'data.h5')!r}")
    if not os.path.isdir(folder):
        raise FileNotFoundError(f"the folder of {path!r} does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise PermissionError(f"cannot write to {folder!r} (read-only or no permission)")
    if os.path.exists(path) and not force:
        raise FileExistsError(f"{path!r} already exists; pass force=True (--force) to "
                              "replace it")


def load_dataset(path: str | os.PathLike[str], *, verify: bool = True) -> Dataset:
    """Load a dataset written by :func:`generate_dataset`.

    Args:
        path: HDF5 file.
        verify: check the stored SHA-256 checksum of the arrays.

    Returns:
        :class:`Dataset`.

    Raises:
        FileNotFoundError: if the file is missing.
        ValueError: if it is not an nh-operators dataset or the checksum differs
            (a corrupted or modified file).
    """
    arrays, attrs = read_dataset(path, verify=verify)
    return Dataset(arrays, attrs)
