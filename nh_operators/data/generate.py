"""Datasets of random bounded potentials with exact trajectory labels.

:func:`generate_dataset` draws potentials from :class:`BoundedPotentialSpace`, labels
them with :func:`reference_solve` on the exact B-spline curve, drops and counts invalid
samples, tops up to exactly n, and streams chunks to an HDF5 file (see :mod:`._h5`).
"""

import numpy as np

from .._constants import SENSORS, TIMES, V0
from .._version import __version__
from ..potentials import BoundedPotential, BoundedPotentialSpace
from ..solvers import reference_solve
from ._h5 import read_dataset, write_streamed

__all__ = ["PRESETS", "Dataset", "generate_dataset", "label_potentials", "load_dataset"]

#: Named datasets of the paper: size and seed.
PRESETS = {
    "standard": {"size": 10_000, "seed": 8407},
    "extended": {"size": 100_000, "seed": 8407},
    "test": {"size": 4_000, "seed": 42},
}

#: Label tolerances: reference solve, energy drift and excursion beyond [0, 1] allowed.
LABEL_RTOL = 1e-15
ENERGY_TOL = 1e-10
BOUNDS_TOL = 1e-9


def label_potentials(potentials, t=TIMES, *, rtol=LABEL_RTOL, energy_tol=ENERGY_TOL):
    """Exact labels of a batch of potentials, with the reason each invalid one fails.

    Args:
        potentials: a batched :class:`BoundedPotential` of N potentials.
        t: query times, shape (M,).
        rtol: tolerance of the reference solve (also its atol).
        energy_tol: largest ``|p²/2 + V(q) - V0|`` accepted.

    Returns:
        (q, p, reasons): q and p of shape (N, M); reasons a list of N strings, empty for
        a valid sample, else one of "non-finite", "left [0, 1]", "energy drift",
        "step budget".
    """
    q, p, info = reference_solve(potentials, t, rtol=rtol, atol=rtol, full_output=True)
    reasons = []
    for qi, pi, energy, steps in zip(q, p, info["energy_error"], info["steps"]):
        if steps < 0:
            reasons.append("step budget")
        elif not (np.all(np.isfinite(qi)) and np.all(np.isfinite(pi))):
            reasons.append("non-finite")
        elif qi.min() < -BOUNDS_TOL or qi.max() > 1 + BOUNDS_TOL:
            reasons.append("left [0, 1]")
        elif not energy <= energy_tol:
            reasons.append("energy drift")
        else:
            reasons.append("")
    return q, p, reasons


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
        attrs: dict of metadata (generator parameters, seed, version, checksum, drops).
    """

    def __init__(self, arrays, attrs):
        self.V = arrays["V"]
        self.x = arrays["x"]
        self.t = arrays["t"]
        self.q = arrays["q"]
        self.p = arrays["p"]
        self.n_grf = arrays["n_grf"]
        self.control_q = arrays["control_q"]
        self.control_V = arrays["control_V"]
        self.length_scale = arrays["length_scale"]
        self.attrs = dict(attrs)

    def __len__(self):
        return self.V.shape[0]

    @property
    def seed(self):
        return int(self.attrs["seed"])

    @property
    def checksum(self):
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

    def split_indices(self, train_fraction=0.8, seed=None):
        """Random train/validation indices (the paper's 80/20 hold-out).

        Args:
            train_fraction: fraction of samples for training, in (0, 1).
            seed: permutation seed; defaults to the dataset's own seed.

        Returns:
            (train, validation) index arrays.
        """
        if not 0 < train_fraction < 1:
            raise ValueError(f"train_fraction must lie in (0, 1), got {train_fraction}")
        rng = np.random.default_rng(self.seed if seed is None else seed)
        order = rng.permutation(len(self))
        n_train = int(round(train_fraction * len(self)))
        return np.sort(order[:n_train]), np.sort(order[n_train:])

    def to_deepxde(self, train_fraction=0.8, seed=None, dtype=np.float32, **kwargs):
        """DeepXDE training data of this dataset: an :class:`~nh_operators.OperatorData`.

        Branch input V (N, 100), trunk input t as (100, 1), targets stack(q, p) of shape
        (N, 100, 2); the validation part is DeepXDE's "test" set. ``OperatorData`` is a
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
        return OperatorData(
            (self.V[train].astype(dtype), trunk), y[train],
            (self.V[val].astype(dtype), trunk), y[val], **kwargs,
        )


def generate_dataset(n, seed, path=None, *, chunk=2000, progress=True, resume=True,
                     rtol=LABEL_RTOL, energy_tol=ENERGY_TOL, **space_kwargs):
    """Generate n potentials with exact labels on :data:`SENSORS` / :data:`TIMES`.

    Potentials are drawn one after another from ``BoundedPotentialSpace(seed,
    **space_kwargs)``; invalid samples (non-finite, leaving [0, 1], energy drift above
    ``energy_tol``) are dropped and counted, and drawing continues until exactly n are
    kept, so the dataset is the first n valid draws of the stream: the same seed and
    parameters give the same arrays whatever the chunk size.

    With ``path``, chunks stream to ``path + ".partial"`` (memory stays at a few
    chunks), which is renamed to ``path`` when complete; an interrupted run resumes from
    the partial file when ``resume`` is true and its parameters match.

    Args:
        n: number of samples (≥ 1).
        seed: int seed of the generator.
        path: optional HDF5 output path.
        chunk: samples labelled per batch.
        progress: show a tqdm progress bar.
        resume: continue a matching ``.partial`` file.
        rtol: tolerance of the reference solve.
        energy_tol: largest accepted energy error.
        **space_kwargs: generator parameters (``n_grf``, ``length_scale``, ``omega``,
            ``margin``).

    Returns:
        :class:`Dataset` (loaded from ``path`` when given).

    Raises:
        ValueError: for n < 1 or bad generator parameters.

    Example:
        >>> ds = generate_dataset(8, seed=0, progress=False)
        >>> ds.V.shape, ds.q.shape
        ((8, 100), (8, 100))
    """
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n}")
    if int(seed) != seed:
        raise ValueError(f"seed must be an integer, got {seed}")
    n, seed = int(n), int(seed)
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
    source = _Source(space, rtol, energy_tol)
    if path is None:
        arrays, drops = source.take(n)
        attrs["dropped"] = drops
        attrs["n_dropped"] = int(sum(drops.values()))
        return Dataset(arrays, attrs)
    write_streamed(path, n, attrs, source, chunk=chunk, progress=progress, resume=resume)
    return load_dataset(path)


class _Source:
    """Draws, labels and filters potentials; remembers how many were dropped and why."""

    def __init__(self, space, rtol, energy_tol):
        self.space = space
        self.rtol = rtol
        self.energy_tol = energy_tol

    def take(self, n, drops=None):
        """The next n valid samples as a dict of arrays, and the drop counts."""
        drops = {} if drops is None else drops
        parts = []
        kept = 0
        while kept < n:
            feats, scales = self.space.random_with_scales(n - kept)
            cq, cv = self.space.controls(feats)
            pots = BoundedPotential(cq, cv)
            q, p, reasons = label_potentials(pots, TIMES, rtol=self.rtol, energy_tol=self.energy_tol)
            ok = np.array([r == "" for r in reasons])
            for r in reasons:
                if r:
                    drops[r] = drops.get(r, 0) + 1
            parts.append({
                "V": pots[ok].V(SENSORS) if ok.any() else np.empty((0, SENSORS.size)),
                "q": q[ok], "p": p[ok], "n_grf": feats[ok, 0].astype(np.int8),
                "control_q": cq[ok], "control_V": cv[ok], "length_scale": scales[ok],
            })
            kept += int(ok.sum())
        arrays = {k: np.concatenate([part[k] for part in parts]) for k in parts[0]}
        arrays["x"] = np.array(SENSORS)
        arrays["t"] = np.array(TIMES)
        return arrays, drops


def load_dataset(path, *, verify=True):
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
