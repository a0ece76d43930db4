"""Four operator problems of the kinds DeepXDE's examples pose, written here.

Used by ``benchmarks/problems/deepxde_problems.py`` (the table) and
``tests/models/test_deepxde_problems.py`` (small, fast versions); not part of the
package's API, which is why it lives beside the benchmark and the test puts this folder
on ``sys.path``.

Each builder returns a :class:`Problem`: a DeepXDE data object to train on (data-driven
``TripleCartesianProd`` or physics-informed ``PDEOperatorCartesianProd``), the network's
shape (m sensors, k outputs, d query coordinates and their range), and test data whose
reference solutions are computed independently of any network:

* ``antiderivative``: u(x) = ∫_0^x v, v a GRF; cumulative trapezoid on the GRF's grid
  (exact for its piecewise-linear interpolant).
* ``poisson``: −u'' = f on [0, 1], u(0) = u(1) = 0 (hard, output x(1 − x)·y), f a GRF;
  the second-order finite-difference solve on a 1,001-point grid.
* ``advection``: u_t + u_x = 0 on [0, 1] (periodic) × [0, 1], u(x, 0) = v(x), v a
  periodic GRF; exact: v(x − t).
* ``stokes``: μΔu − ∇p = 0, ∇·u = 0 in the unit square, u = (g(x), 0) on the lid
  y = 1, no slip elsewhere, g = x(1 − x)·w(x) with w a GRF; outputs (u, v, p).
  Reference: the biharmonic stream-function equation by finite differences on a
  33 × 33 grid (coarse: about 1 % from the converged solution), compared on its nodes;
  the metric covers the velocity (u, v) only (p is fixed up to a constant).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional

import numpy as np

from nh_operators._backend import ensure_pytorch_backend
from references import cumulative_trapezoid, poisson_fd, stokes_velocity

dde = ensure_pytorch_backend()  # DeepXDE on PyTorch, imported quietly

__all__ = ["GRF", "PeriodicGRF", "Problem", "PROBLEMS", "build_problem", "relative_l2"]


class GRF(dde.data.function_spaces.FunctionSpace):
    """A zero-mean Gaussian random field on [a, b] with a squared-exponential kernel.

    Samples are the field's values on a uniform grid of ``n_grid`` points (drawn as
    L z with L the Cholesky factor of the kernel matrix plus a small jitter); between
    the nodes a sample is its piecewise-linear interpolant.

    Args:
        length_scale: correlation length ℓ of k(x, y) = σ² exp(−(x − y)² / (2ℓ²)).
        sigma: standard deviation σ (default 1).
        n_grid: grid points (default 1,001).
        domain: (a, b) (default (0, 1)).
        seed: seed of the generator (the only source of randomness).

    Raises:
        ValueError: for a non-positive length scale or fewer than 2 grid points; in
            ``eval_batch`` for points outside the domain.

    Example:
        >>> grf = GRF(0.2, n_grid=101, seed=0)
        >>> v = grf.random(3)
        >>> v.shape, grf.eval_batch(v, np.array([[0.0], [1.0]])).shape
        ((3, 101), (3, 2))
    """

    def __init__(self, length_scale: float, sigma: float = 1.0, n_grid: int = 1001,
                 domain: tuple = (0.0, 1.0), seed: int = 0) -> None:
        if length_scale <= 0 or n_grid < 2:
            raise ValueError(f"GRF needs length_scale > 0 and n_grid >= 2, got "
                             f"{length_scale} and {n_grid}")
        self.domain = (float(domain[0]), float(domain[1]))
        self.x = np.linspace(*self.domain, n_grid)
        K = sigma ** 2 * np.exp(-0.5 * (self.x[:, None] - self.x[None]) ** 2
                                / length_scale ** 2)
        self.L = np.linalg.cholesky(K + 1e-10 * sigma ** 2 * np.eye(n_grid))
        self.rng = np.random.default_rng(seed)

    def random(self, size: int) -> np.ndarray:
        """(size, n_grid) values of ``size`` fresh samples on the grid."""
        return (self.L @ self.rng.standard_normal((len(self.x), size))).T

    def eval_one(self, feature: np.ndarray, x: np.ndarray) -> float:
        """One sample (n_grid,) at one point x (1,)."""
        return float(self.eval_batch(feature[None], np.reshape(x, (1, 1)))[0, 0])

    def eval_batch(self, features: np.ndarray, xs: np.ndarray) -> np.ndarray:
        """Samples (n, n_grid) at points xs (M, 1): (n, M) in DeepXDE's float."""
        x = np.asarray(xs, dtype=np.float64).reshape(-1)
        if x.min() < self.domain[0] - 1e-12 or x.max() > self.domain[1] + 1e-12:
            raise ValueError(f"GRF points must lie in {self.domain}; got "
                             f"{x.min():g} to {x.max():g}")
        h = self.x[1] - self.x[0]
        i = np.clip(((x - self.x[0]) // h).astype(int), 0, len(self.x) - 2)
        w = (x - self.x[i]) / h
        out = features[:, i] * (1 - w) + features[:, i + 1] * w
        return out.astype(dde.config.real(np))


class PeriodicGRF(dde.data.function_spaces.FunctionSpace):
    """A periodic Gaussian random field on [0, 1]: a random Fourier series.

    v(x) = a_0 s_0 + Σ_{k=1}^{K} s_k (a_k cos 2πkx + b_k sin 2πkx), a, b ~ N(0, 1),
    s_k = exp(−(2πkℓ)² / 4) normalised so that Σ s_k² (the variance) is 1: smooth,
    with period 1, and exact to evaluate anywhere.

    Args:
        length_scale: ℓ (default 0.15: about three modes matter).
        modes: K (default 8).
        seed: seed of the generator.

    Example:
        >>> v = PeriodicGRF(seed=0).random(2)
        >>> np.allclose(PeriodicGRF().eval_batch(v, np.array([[0.0]])),
        ...             PeriodicGRF().eval_batch(v, np.array([[1.0]])), atol=1e-6)
        True
    """

    def __init__(self, length_scale: float = 0.15, modes: int = 8, seed: int = 0) -> None:
        k = np.arange(modes + 1)
        s = np.exp(-((2 * np.pi * k * length_scale) ** 2) / 4)
        self.k, self.s = k, s / np.sqrt(np.sum(s ** 2))
        self.rng = np.random.default_rng(seed)

    def random(self, size: int) -> np.ndarray:
        """(size, 2 (K + 1)) coefficients (a, b) of ``size`` samples."""
        return self.rng.standard_normal((size, 2 * len(self.k)))

    def eval_one(self, feature: np.ndarray, x: np.ndarray) -> float:
        """One sample at one point."""
        return float(self.eval_batch(feature[None], np.reshape(x, (1, 1)))[0, 0])

    def eval_batch(self, features: np.ndarray, xs: np.ndarray) -> np.ndarray:
        """Samples (n, 2 (K + 1)) at points xs (M, 1): (n, M) in DeepXDE's float."""
        phase = 2 * np.pi * np.asarray(xs, dtype=np.float64).reshape(-1, 1) * self.k
        a, b = np.split(features, 2, axis=1)
        out = (a * self.s) @ np.cos(phase).T + (b * self.s) @ np.sin(phase).T
        return out.astype(dde.config.real(np))


def relative_l2(pred: np.ndarray, ref: np.ndarray) -> float:
    """Mean over functions of ||pred − ref||₂ / ||ref||₂ (all points and outputs).

    Args:
        pred, ref: (n, M) or (n, M, k).

    Example:
        >>> relative_l2(np.array([[1.0, 1.0]]), np.array([[1.0, 2.0]]))
        0.4472135954999579
    """
    n = len(ref)
    err = np.linalg.norm((pred - ref).reshape(n, -1), axis=1)
    return float(np.mean(err / np.linalg.norm(ref.reshape(n, -1), axis=1)))


@dataclass
class Problem:
    """A training data object, the network's shape and independent test data.

    Attributes:
        name: the problem's name.
        data: the DeepXDE data object to train on.
        n_sensors, n_outputs, query_dim: m, k, d for ``nh.build_model``.
        query_range: (lo, hi) of every query coordinate.
        test_v: (n, m) sensor values of the test functions.
        test_x: (M, d) test points.
        test_u: (n, M) or (n, M, k_eval) reference solutions there.
        metric_outputs: outputs the metric compares (None: all).
        output_transform: DeepXDE output transform (hard constraints) or None.
        physics_informed: trained on PDE residuals (needs ``query_coupled=False``).
        grid_points: points per coordinate of the training/test grids (sets TraONet's
            and MambONet's ``time_scale`` and the FNO's ``n_grid``).
        batch_size: functions per batch for ``dde.Model.train`` (data-driven problems;
            a physics-informed data object batches itself).
        sizes: the sizes the builder used, for the table's header.
    """

    name: str
    data: object
    n_sensors: int
    n_outputs: int
    query_dim: int
    query_range: tuple
    test_v: np.ndarray
    test_x: np.ndarray
    test_u: np.ndarray
    metric_outputs: Optional[list] = None
    output_transform: Optional[Callable] = None
    physics_informed: bool = True
    grid_points: int = 50
    batch_size: Optional[int] = None
    sizes: dict = field(default_factory=dict)

    def metric(self, pred: np.ndarray) -> float:
        """Mean relative l2 error of predictions (n, M[, k]) on the test functions."""
        if self.metric_outputs is not None:
            pred = pred[..., self.metric_outputs]
        return relative_l2(np.asarray(pred, dtype=np.float64), self.test_u)


def _real(a: np.ndarray) -> np.ndarray:
    return np.asarray(a, dtype=dde.config.real(np))


def antiderivative(n_train: int = 500, n_test: int = 200, m: int = 50, n_points: int = 50,
                   batch_size: int = 50, seed: int = 0) -> Problem:
    """Data-driven u(x) = ∫_0^x v, v a GRF (ℓ = 0.2), sensors and points on [0, 1].

    Args:
        n_train, n_test: training and test functions; m: sensors (uniform on [0, 1]);
            the other sizes: collocation / query points; batch_size: functions per
            step; seed: seed of the function sampler.

    Returns:
        The :class:`Problem`.
    """
    grf = GRF(0.2, n_grid=1001, seed=seed)
    sensors = np.linspace(0, 1, m)[:, None]
    nodes = np.round(np.linspace(0, len(grf.x) - 1, n_points)).astype(int)
    x = grf.x[nodes, None]  # on the GRF's grid, where the trapezoid rule is exact

    def split(n: int):
        v = grf.random(n)
        return _real(grf.eval_batch(v, sensors)), cumulative_trapezoid(v, grf.x)[:, nodes]

    v_tr, u_tr = split(n_train)
    v_te, u_te = split(n_test)
    data = dde.data.TripleCartesianProd((v_tr, _real(x)), _real(u_tr), (v_te, _real(x)),
                                        _real(u_te))
    return Problem("antiderivative", data, m, 1, 1, (0.0, 1.0), v_te, _real(x), u_te,
                   physics_informed=False, grid_points=n_points, batch_size=batch_size,
                   sizes=dict(train=n_train, test=n_test, m=m, points=n_points))


def poisson(n_train: int = 200, n_test: int = 100, m: int = 50, n_points: int = 64,
            batch_size: int = 16, seed: int = 1) -> Problem:
    """Physics-informed −u'' = f, u(0) = u(1) = 0 (hard), f a GRF (ℓ = 0.2).

    Args:
        n_train, n_test: training and test functions; m: sensors (uniform on [0, 1]);
            the other sizes: collocation / query points; batch_size: functions per
            step; seed: seed of the function sampler.

    Returns:
        The :class:`Problem`.
    """
    grf = GRF(0.2, n_grid=1001, seed=seed)
    geom = dde.geometry.Interval(0, 1)

    def pde(x, y, f):
        return -dde.grad.hessian(y, x) - f

    pde_data = dde.data.PDE(geom, pde, [], num_domain=n_points - 2, num_boundary=2,
                            train_distribution="uniform")
    sensors = np.linspace(0, 1, m)[:, None]
    data = dde.data.PDEOperatorCartesianProd(pde_data, grf, sensors, n_train,
                                             num_test=batch_size, batch_size=batch_size)
    f = grf.random(n_test)
    x = np.linspace(0, 1, 101)[:, None]
    u = poisson_fd(f, grf.x)[:, ::10]

    def hard_bc(inputs, y):
        t = inputs[1][:, 0]
        return y * (t * (1 - t))

    return Problem("poisson", data, m, 1, 1, (0.0, 1.0), grf.eval_batch(f, sensors),
                   _real(x), u, output_transform=hard_bc, grid_points=n_points,
                   sizes=dict(train=n_train, test=n_test, m=m, points=n_points))


def advection(n_train: int = 200, n_test: int = 100, m: int = 50, n_domain: int = 144,
              n_edge: int = 24, batch_size: int = 8, seed: int = 2) -> Problem:
    """Physics-informed u_t + u_x = 0, periodic in x, u(x, 0) = v(x), v periodic GRF.

    Args:
        n_train, n_test: training and test functions; m: sensors (uniform on [0, 1]);
            the other sizes: collocation / query points; batch_size: functions per
            step; seed: seed of the function sampler.

    Returns:
        The :class:`Problem`.
    """
    space = PeriodicGRF(seed=seed)
    geomtime = dde.geometry.GeometryXTime(dde.geometry.Interval(0, 1),
                                          dde.geometry.TimeDomain(0, 1))

    def pde(x, y, v):
        return dde.grad.jacobian(y, x, j=1) + dde.grad.jacobian(y, x, j=0)

    periodic = dde.icbc.PeriodicBC(geomtime, 0, lambda x, on: on)
    initial = dde.icbc.IC(geomtime, lambda x, v: v, lambda x, on: on)
    pde_data = dde.data.TimePDE(geomtime, pde, [periodic, initial], num_domain=n_domain,
                                num_boundary=n_edge, num_initial=n_edge,
                                train_distribution="uniform")
    sensors = np.linspace(0, 1, m)[:, None]
    data = dde.data.PDEOperatorCartesianProd(pde_data, space, sensors, n_train,
                                             function_variables=[0], num_test=batch_size,
                                             batch_size=batch_size)
    coef = space.random(n_test)
    g = np.linspace(0, 1, 33)
    x = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    u = space.eval_batch(coef, ((x[:, :1] - x[:, 1:]) % 1.0)).astype(np.float64)
    return Problem("advection", data, m, 1, 2, (0.0, 1.0), space.eval_batch(coef, sensors),
                   _real(x), u, grid_points=33,
                   sizes=dict(train=n_train, test=n_test, m=m, points=n_domain))


def stokes(n_train: int = 100, n_test: int = 50, m: int = 25, n_domain: int = 100,
           n_boundary: int = 40, batch_size: int = 4, seed: int = 3) -> Problem:
    """Physics-informed Stokes flow in the lid-driven unit cavity (μ = 1), lid u = g(x).

    Args:
        n_train, n_test: training and test functions; m: sensors (uniform on [0, 1]);
            the other sizes: collocation / query points; batch_size: functions per
            step; seed: seed of the function sampler.

    Returns:
        The :class:`Problem`.
    """
    grf = GRF(0.2, n_grid=1001, seed=seed)
    geom = dde.geometry.Rectangle([0, 0], [1, 1])

    class Lid(dde.data.function_spaces.FunctionSpace):
        """g(x) = x (1 − x) w(x), w from the GRF: zero at the corners."""

        def random(self, size):
            return grf.random(size) * 4 * grf.x * (1 - grf.x)

        def eval_one(self, feature, x):
            return grf.eval_one(feature, x)

        def eval_batch(self, features, xs):
            return grf.eval_batch(features, xs)

    def pde(x, y, g):
        lap = [dde.grad.hessian(y, x, component=c, i=0, j=0)
               + dde.grad.hessian(y, x, component=c, i=1, j=1) for c in (0, 1)]
        px = dde.grad.jacobian(y, x, i=2, j=0)
        py = dde.grad.jacobian(y, x, i=2, j=1)
        div = dde.grad.jacobian(y, x, i=0, j=0) + dde.grad.jacobian(y, x, i=1, j=1)
        return [lap[0] - px, lap[1] - py, div]

    top = lambda x, on: on and np.isclose(x[1], 1.0)  # noqa: E731
    walls = lambda x, on: on and not np.isclose(x[1], 1.0)  # noqa: E731
    bcs = [dde.icbc.DirichletBC(geom, lambda x, g: g, top, component=0),
           dde.icbc.DirichletBC(geom, lambda x: 0.0, walls, component=0),
           dde.icbc.DirichletBC(geom, lambda x: 0.0, lambda x, on: on, component=1)]
    pde_data = dde.data.PDE(geom, pde, bcs, num_domain=n_domain, num_boundary=n_boundary,
                            train_distribution="uniform")
    sensors = np.linspace(0, 1, m)[:, None]
    lid = Lid()
    data = dde.data.PDEOperatorCartesianProd(pde_data, lid, sensors, n_train,
                                             function_variables=[0], num_test=batch_size,
                                             batch_size=batch_size)
    g_test = lid.random(n_test)
    n = 32
    nodes = np.linspace(0, 1, n + 1)
    uv = stokes_velocity(lid.eval_batch(g_test, nodes[:, None]).astype(np.float64), n)
    x = np.stack(np.meshgrid(nodes, nodes, indexing="ij"), -1).reshape(-1, 2)
    return Problem("stokes", data, m, 3, 2, (0.0, 1.0), lid.eval_batch(g_test, sensors),
                   _real(x), uv.reshape(n_test, -1, 2), metric_outputs=[0, 1],
                   grid_points=33,
                   sizes=dict(train=n_train, test=n_test, m=m, points=n_domain))


#: The builders, by name.
PROBLEMS = {"antiderivative": antiderivative, "poisson": poisson, "advection": advection,
            "stokes": stokes}


def build_problem(name: str, **sizes) -> Problem:
    """The problem ``name`` (a key of :data:`PROBLEMS`) with its builder's ``sizes``.

    Raises:
        ValueError: for an unknown name.
    """
    if name not in PROBLEMS:
        raise ValueError(f"unknown problem {name!r}; choose from {sorted(PROBLEMS)}")
    return PROBLEMS[name](**sizes)
