"""The paper's random bounded potentials (its Algorithm 1) as a DeepXDE function space."""

from typing import Any, Literal

import numpy as np

from .._backend import ensure_pytorch_backend
from .._constants import V0
from .bounded import BoundedPotential
from .bspline import MAX_CONTROL
from .gaussian import DRAW_VERSION, grf_values

_dde: Any = ensure_pytorch_backend()  # deepxde ships no type information
FunctionSpace = _dde.data.function_spaces.FunctionSpace

__all__ = ["BoundedPotentialSpace", "NORMALIZATIONS"]

MAX_GRF = MAX_CONTROL - 2
#: How GRF values become control values: each potential on its own (Algorithm 1 as
#: printed) or a whole pool of candidates at once (the paper's reference code).
NORMALIZATIONS = ("potential", "batch")
#: :data:`NORMALIZATIONS` as a type (``BoundedPotentialSpace``'s ``normalization``).
Normalization = Literal["potential", "batch"]


def _as_generator(seed):
    if isinstance(seed, np.random.Generator):
        return seed
    if seed is None or isinstance(seed, (int, np.integer)):
        return np.random.default_rng(seed)
    raise TypeError(f"seed must be an int, None or a numpy.random.Generator, got {type(seed)!r}")


def _points(x: np.ndarray | float) -> np.ndarray:
    """Points as a flat float64 array, checked to lie in the potentials' domain [0, 1]."""
    x = np.asarray(x, dtype=np.float64).reshape(-1)
    inside = (x >= 0.0) & (x <= 1.0)   # False for NaN as well
    if not np.all(inside):
        bad = x[~inside]
        raise ValueError(f"BoundedPotentialSpace: the potentials live on [0, 1] and are not "
                         f"extrapolated; got {bad.size} point(s) outside it, ranging from "
                         f"{bad.min():g} to {bad.max():g}")
    return x


class BoundedPotentialSpace(FunctionSpace):
    """Random bounded potentials: a GRF drawn at a few nodes, placed on a B-spline.

    For each potential (the paper's Algorithm 1 with L = 1, V0 = 2):

    1. n_GRF ~ uniform on {n_min, ..., n_max} and a length scale l ~ U(l_min, l_max);
    2. X ~ N(0, K) with the squared-exponential kernel
       K_ij = exp(-(y_i - y_j)² / (2 l²)) at y_i = i / (n_GRF + 1), as X = L z with L
       the Cholesky factor of K, computed in plain loops
       (:mod:`~nh_operators.potentials.gaussian`), so the same seed gives the same bits
       on any CPU;
    3. X is normalised to control values V_i; the paper maps min X to V0 and max X to
       -V0, which puts one interior control value exactly at V0. Then V'(0) = 0 when
       that value is V_1, and with n_GRF = 2 the particle never moves. Here the
       normalisation is V_i = V0 - 2 V0 (margin + (1 - margin) u_i) with
       u_i = (X_i - min X) / (max X - min X), so interior values lie in
       [-V0, V0 (1 - 2 margin)] and stay strictly below V0 (default margin 0.05:
       at most 1.8). Since the B-spline is a convex combination of its control points
       with the end weights below 1 inside, V < V0 on (0, 1) and V'(0) < 0, V'(1) > 0;
    4. abscissae q_0 = 0, q_i drawn uniformly from the i-th of n_GRF equal cells shrunk
       by ω (ω from the ends), q_{n_GRF+1} = 1; ω = 0.05 keeps the walls from
       becoming too steep;
    5. V is the clamped cubic B-spline curve through (q_i, V_i) with uniform knots.

    Each potential is drawn from the generator in turn (n_GRF, l, the GRF normals, the
    abscissae), so the k-th potential does not depend on how many are drawn at once.

    **The reference code's distribution** (``normalization="batch"``). The paper's
    tables were not made with step 3 as printed: the authors' code draws ``pool``
    candidates (1.25 n for a dataset of n) and min-max normalises the GRF values of *all*
    of them at once, V_i = V0 - 2 V0 u_i with u over the whole pool, so most potentials
    get shallow, gentle interiors (interior control values of mean ≈ 0.1 and std ≈ 0.5,
    against the full [-2, 1.8] of every potential here). The candidates are drawn
    exactly as above (n_GRF, l, normals, abscissae, in turn), then normalised together;
    the one candidate whose value maps to V0 itself (the pool's minimum) is skipped, so
    the interior stays strictly below V0 (:attr:`skipped` counts it), and candidates
    are served in order. The pool is drawn on first use from the seeded generator, so
    it depends only on the seed and ``pool``; asking for more potentials than the pool
    holds is an error.

    Features (DeepXDE's ``random`` format) have shape (n, 1 + 2 MAX_GRF) = (n, 15):
    ``[n_GRF, q_1..q_7, V_1..V_7]``, NaN beyond n_GRF. They rebuild the potential
    exactly.

    **DeepXDE's conventions.** :meth:`eval_batch` and :meth:`eval_one` return
    ``dde.config.real``'s dtype (float32 unless ``dde.config.set_default_float`` says
    otherwise), so their values go straight into DeepXDE's data objects; pass
    ``dtype=np.float64`` (or use :meth:`potentials`, always float64) for numerics. Points
    outside [0, 1] raise a ValueError, as DeepXDE's ``GRF`` does. With ``seed=None`` the
    space follows DeepXDE's global seed: after ``dde.config.set_random_seed(s)`` it draws
    as ``seed=s`` would (the seed is read at the first draw); with no global seed either,
    it draws from fresh OS entropy.

    Args:
        seed: int, None or ``numpy.random.Generator``; the space owns its generator
            (``None``: DeepXDE's global seed, see above).
        n_grf: (min, max) number of interior control points, both in [2, 7].
        length_scale: (min, max) of the GRF length scale.
        omega: the stability parameter ω, in (0, 1 / (2 max n_GRF)).
        margin: fraction of the 2 V0 range kept free below V0, in (0, 1)
            (``normalization="potential"`` only).
        normalization: ``"potential"`` (Algorithm 1, each potential on its own) or
            ``"batch"`` (the reference code: the whole pool at once).
        pool: the number of candidates normalised together (required for ``"batch"``).

    Example:
        >>> space = BoundedPotentialSpace(seed=1)
        >>> feats = space.random(3)
        >>> np.round(space.eval_batch(feats, np.array([[0.0], [1.0]])), 12).tolist()
        [[2.0, 2.0], [2.0, 2.0], [2.0, 2.0]]
    """

    def __init__(self, seed=None, *, n_grf=(2, 7), length_scale=(0.01, 0.2), omega=0.05,
                 margin=0.05, normalization: Normalization = "potential",
                 pool: int | None = None):
        lo, hi = n_grf
        if not 2 <= lo <= hi <= MAX_GRF:
            raise ValueError(f"n_grf must satisfy 2 <= min <= max <= {MAX_GRF}, got {n_grf}")
        if not 0 < length_scale[0] <= length_scale[1]:
            raise ValueError(f"length_scale must be 0 < min <= max, got {length_scale}")
        if not 0 < omega < 1 / (2 * hi):
            raise ValueError(f"omega must lie in (0, 1/(2 n_grf_max)) = (0, {1 / (2 * hi):.4g})")
        if not 0 < margin < 1:
            raise ValueError(f"margin must lie in (0, 1), got {margin}")
        if normalization not in NORMALIZATIONS:
            raise ValueError(f"normalization must be one of {NORMALIZATIONS}, got "
                             f"{normalization!r}")
        if normalization == "batch" and not (isinstance(pool, (int, np.integer)) and pool >= 2):
            raise ValueError(f"normalization='batch' needs pool, the number of candidates "
                             f"normalised together (an integer >= 2), got {pool!r}")
        if normalization == "potential" and pool is not None:
            raise ValueError("pool is only used with normalization='batch'")
        self.normalization = normalization
        self.pool = None if pool is None else int(pool)
        self._candidates = None  # the normalised pool, drawn on first use
        self.cursor = 0  # candidates of the pool served (or skipped) so far
        self.skipped = 0  # candidates skipped: an interior control value at V0
        # None: made at the first draw, from DeepXDE's global seed as it is then
        self._rng = None if seed is None else _as_generator(seed)
        self.n_grf = (int(lo), int(hi))
        self.length_scale = (float(length_scale[0]), float(length_scale[1]))
        self.omega = float(omega)
        self.margin = float(margin)

    @property
    def rng(self) -> np.random.Generator:
        """The space's generator; with ``seed=None``, seeded from ``dde.config.random_seed``
        (read here, on first use: DeepXDE's spaces draw from the global stream that
        ``dde.config.set_random_seed`` seeds, whenever they draw)."""
        if self._rng is None:
            self._rng = np.random.default_rng(_dde.config.random_seed)
        return self._rng

    def params(self):
        """The generator parameters, as stored with a dataset (``draw``: the version of
        the Gaussian draw, :data:`~nh_operators.potentials.gaussian.DRAW_VERSION`)."""
        params = {"n_grf": list(self.n_grf), "length_scale": list(self.length_scale),
                  "omega": self.omega, "margin": self.margin, "V0": V0, "L": 1.0,
                  "draw": DRAW_VERSION}
        if self.normalization == "batch":  # stored only when not Algorithm 1's default
            params.update(normalization="batch", pool=self.pool)
        return params

    def state(self):
        """Where the stream of potentials stands, as JSON-able data (for a resume)."""
        if self.normalization == "batch":
            return {"cursor": self.cursor, "skipped": self.skipped}
        return {"rng": self.rng.bit_generator.state}

    def set_state(self, state):
        """Continue the stream from a :meth:`state` of a space built with the same seed."""
        if self.normalization == "batch":
            self.cursor, self.skipped = int(state["cursor"]), int(state["skipped"])
        else:
            self.rng.bit_generator.state = state["rng"]

    def _draw_raw(self):
        rng = self.rng
        n = int(rng.integers(self.n_grf[0], self.n_grf[1] + 1))
        ell = rng.uniform(*self.length_scale)
        # draw 2: plain loops, the same bits on any CPU (draw 1 was np.exp and
        # np.linalg.cholesky(cov) @ z); the same random numbers in the same order
        x = grf_values(n, ell, rng.standard_normal(n))
        i = np.arange(1, n + 1)
        low = (i - 1) / n + self.omega / 2
        high = i / n - self.omega / 2
        low[0] = self.omega
        high[-1] = 1 - self.omega
        qs = rng.uniform(low, high)
        return n, ell, x, qs

    def _draw_pool(self, pool: int):
        raws = [self._draw_raw() for _ in range(pool)]
        lo = min(r[2].min() for r in raws)
        hi = max(r[2].max() for r in raws)
        # the reference code: V = V0 - 2 V0 (X - min) / (max - min) over the whole pool
        return [(n, ell, qs, V0 - 2 * V0 * (x - lo) / (hi - lo)) for n, ell, x, qs in raws]

    def _draw_one(self):
        if self.normalization == "batch":
            pool = self.pool
            assert pool is not None  # __init__ requires it with "batch"
            if self._candidates is None:
                self._candidates = self._draw_pool(pool)
            while True:
                if self.cursor >= pool:
                    raise ValueError(f"the pool of {self.pool} candidates is used up; draw "
                                     "a larger pool (normalization='batch')")
                n, ell, qs, values = self._candidates[self.cursor]
                self.cursor += 1
                if values.max() < V0:
                    return n, ell, qs, values
                self.skipped += 1
        n, ell, x, qs = self._draw_raw()
        u = (x - x.min()) / (x.max() - x.min())
        values = V0 - 2 * V0 * (self.margin + (1 - self.margin) * u)
        return n, ell, qs, values

    def random_with_scales(self, size):
        """Like :meth:`random`, also returning the drawn length scales, shape (size,)."""
        feats = np.full((size, 1 + 2 * MAX_GRF), np.nan)
        scales = np.empty(size)
        for k in range(size):
            n, scales[k], qs, values = self._draw_one()
            feats[k, 0] = n
            feats[k, 1 : 1 + n] = qs
            feats[k, 1 + MAX_GRF : 1 + MAX_GRF + n] = values
        return feats, scales

    def random(self, size):
        """Draw ``size`` potentials; returns their features, shape (size, 15)."""
        return self.random_with_scales(size)[0]

    @staticmethod
    def controls(features):
        """Full control points (with the ends) from features: two (n, 9) arrays, NaN-padded."""
        feats = np.atleast_2d(np.asarray(features, dtype=np.float64))
        n = feats.shape[0]
        counts = feats[:, 0].astype(int)
        cq = np.full((n, MAX_CONTROL), np.nan)
        cv = np.full((n, MAX_CONTROL), np.nan)
        for k, m in enumerate(counts):
            cq[k, : m + 2] = np.concatenate([[0.0], feats[k, 1 : 1 + m], [1.0]])
            cv[k, : m + 2] = np.concatenate([[V0], feats[k, 1 + MAX_GRF : 1 + MAX_GRF + m], [V0]])
        return cq, cv

    @classmethod
    def potentials(cls, features):
        """The exact potentials of features, as one batched :class:`BoundedPotential`."""
        return BoundedPotential(*cls.controls(features))

    def eval_one(self, feature: np.ndarray, x: np.ndarray | float, *,
                 dtype: type | None = None) -> np.ndarray | np.floating:
        """V of one potential at x.

        Args:
            feature: (15,) features of one potential.
            x: a point or an array of points in [0, 1].
            dtype: the result's dtype (default ``dde.config.real(np)``: float32 unless
                DeepXDE is set to float64); the values are computed in float64.

        Returns:
            A NumPy scalar of ``dtype`` for one point, else an array (n_points,).

        Raises:
            ValueError: for points outside [0, 1].

        Example:
            >>> space = BoundedPotentialSpace(seed=1)
            >>> v = space.eval_one(space.random(1)[0], 1.0)
            >>> v.dtype, round(float(v), 6)
            (dtype('float32'), 2.0)
        """
        dtype = _dde.config.real(np) if dtype is None else dtype
        values = self.potentials(np.asarray(feature)[None, :])[0].V(_points(x)).astype(dtype)
        return values[0] if values.size == 1 else values

    def eval_batch(self, features: np.ndarray, xs: np.ndarray, *,
                   dtype: type | None = None) -> np.ndarray:
        """V of every potential at every point.

        Args:
            features: (n_functions, 15) features.
            xs: (n_points, 1) points in [0, 1].
            dtype: the result's dtype (default ``dde.config.real(np)``, as DeepXDE's own
                spaces); the values are computed in float64, so ``np.float64`` gives
                them exactly.

        Returns:
            (n_functions, n_points) array of ``dtype``.

        Raises:
            ValueError: for points outside [0, 1] (DeepXDE's ``GRF`` raises too).

        Example:
            >>> space = BoundedPotentialSpace(seed=1)
            >>> space.eval_batch(space.random(2), np.array([[0.0], [0.5]])).dtype
            dtype('float32')
        """
        dtype = _dde.config.real(np) if dtype is None else dtype
        return self.potentials(features).V(_points(xs)).astype(dtype, copy=False)
