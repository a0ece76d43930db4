"""Tests of BoundedPotentialSpace, the paper's random bounded potentials."""

import contextlib
import io
import re

import numpy as np
import pytest
from scipy.interpolate import BSpline

# nh_operators first: it selects DeepXDE's PyTorch backend before deepxde is imported
from nh_operators import V0, BoundedPotential, BoundedPotentialSpace  # isort: skip
from nh_operators.potentials.bspline import MAX_CONTROL, clamped_knots  # isort: skip
from nh_operators._backend import ensure_pytorch_backend  # isort: skip
from deepxde.data.function_spaces import FunctionSpace  # isort: skip

MAX_GRF = MAX_CONTROL - 2
N_FEATURES = 1 + 2 * MAX_GRF


@pytest.fixture(scope="module")
def features():
    return BoundedPotentialSpace(seed=2024).random(300)


@pytest.fixture(scope="module")
def potentials(features):
    return BoundedPotentialSpace.potentials(features)


def test_is_a_deepxde_function_space():
    space = BoundedPotentialSpace(seed=0)
    assert isinstance(space, FunctionSpace)
    feats = space.random(4)
    assert feats.shape == (4, N_FEATURES)
    assert space.eval_batch(feats, np.linspace(0, 1, 7)[:, None]).shape == (4, 7)


def test_feature_layout(features):
    counts = features[:, 0]
    assert np.all(counts == np.round(counts))
    for row in features:
        n = int(row[0])
        qs, vs = row[1 : 1 + MAX_GRF], row[1 + MAX_GRF :]
        assert np.all(np.isfinite(qs[:n])) and np.all(np.isnan(qs[n:]))
        assert np.all(np.isfinite(vs[:n])) and np.all(np.isnan(vs[n:]))
    cq, cv = BoundedPotentialSpace.controls(features)
    assert cq.shape == cv.shape == (len(features), MAX_CONTROL)
    for k, n in enumerate(counts.astype(int)):
        assert cq[k, 0] == 0.0 and cq[k, n + 1] == 1.0
        assert cv[k, 0] == V0 and cv[k, n + 1] == V0
        np.testing.assert_array_equal(cq[k, 1 : n + 1], features[k, 1 : n + 1])
        assert np.all(np.isnan(cq[k, n + 2 :]))


def test_boundary_values(potentials):
    ends = potentials.V(np.array([0.0, 1.0]))
    np.testing.assert_allclose(ends, V0, rtol=0, atol=1e-13)


def test_interior_strictly_below_V0(potentials):
    x = np.linspace(0.0, 1.0, 4001)[1:-1]
    values = potentials.V(x)
    assert np.all(values < V0)
    assert np.all(np.isfinite(values))
    # the walls stay below V0 near the ends too
    near = np.array([1e-9, 1e-6, 1 - 1e-6, 1 - 1e-9])
    assert np.all(potentials.V(near) < V0)


def test_control_values_follow_the_normalisation(features):
    # V_i = V0 - 2 V0 (margin + (1 - margin) u_i), u = min-max normalised GRF:
    # the smallest interior value is exactly -V0, the largest V0 (1 - 2 margin) = 1.8
    vs = features[:, 1 + MAX_GRF :]
    np.testing.assert_allclose(np.nanmin(vs, axis=1), -V0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.nanmax(vs, axis=1), V0 * (1 - 2 * 0.05), rtol=0, atol=1e-14)
    other = BoundedPotentialSpace(seed=5, margin=0.3).random(50)[:, 1 + MAX_GRF :]
    np.testing.assert_allclose(np.nanmax(other, axis=1), V0 * (1 - 2 * 0.3), rtol=0, atol=1e-14)
    np.testing.assert_allclose(np.nanmin(other, axis=1), -V0, rtol=0, atol=1e-14)


def test_end_slopes(features, potentials):
    # a clamped B-spline leaves its ends along the control legs: V'(0) = (V_1 - V0) / q_1
    cq, cv = BoundedPotentialSpace.controls(features)
    counts = features[:, 0].astype(int)
    rows = np.arange(len(features))
    slope0 = potentials.dV(0.0)
    slope1 = potentials.dV(1.0)
    np.testing.assert_allclose(slope0, (cv[:, 1] - V0) / cq[:, 1], rtol=1e-12)
    last_q, last_v = cq[rows, counts], cv[rows, counts]
    np.testing.assert_allclose(slope1, (V0 - last_v) / (1 - last_q), rtol=1e-12)
    assert np.all(slope0 < 0)
    assert np.all(slope1 > 0)


def _max_step(values):
    return np.abs(np.diff(values, axis=-1)).max(axis=-1)


def test_numerically_C2(potentials):
    """V, V', V'' are continuous: their largest grid increment shrinks like h.

    A jump J would keep the largest increment at ≥ J however fine the grid; a Lipschitz
    function's largest increment is ≈ h max|derivative|, so refining h by 4 divides it
    by ≈ 4.
    """
    pots = potentials[:100]
    coarse = np.linspace(0.0, 1.0, 2001)
    fine = np.linspace(0.0, 1.0, 8001)
    for f in ("V", "dV", "d2V"):
        ratio = _max_step(getattr(pots, f)(fine)) / _max_step(getattr(pots, f)(coarse))
        assert np.all(ratio < 0.35), (f, ratio.max())
    # and each derivative is the derivative of the one before (central differences)
    h = fine[1] - fine[0]
    for f, df in (("V", "dV"), ("dV", "d2V")):
        g = getattr(pots, f)(fine)
        dg = getattr(pots, df)(fine[1:-1])
        scale = 1 + np.abs(dg).max(axis=1, keepdims=True)
        fd = (g[:, 2:] - g[:, :-2]) / (2 * h)
        assert np.all(np.abs(fd - dg) / scale < 1e-3), f


def test_not_C3_at_the_knots(features, potentials):
    """The third derivative jumps at the images of the interior knots (C² only)."""
    rows = np.flatnonzero(features[:100, 0] >= 4)  # at least two interior knots
    cq, cv = BoundedPotentialSpace.controls(features[rows])
    eps = 1e-4
    jumps = []
    for k, i in enumerate(rows):
        n = int(np.sum(np.isfinite(cq[k])))
        knots = clamped_knots(n)
        curve_q = BSpline(knots, cq[k, :n], 3)
        pot = potentials[int(i)]
        # the size of V''' on this potential, from V'' on a grid
        scale = _max_step(pot.d2V(np.linspace(0, 1, 1001))) * 1000
        for lam in np.unique(knots)[1:-1]:
            qk = float(curve_q(lam))
            d2 = pot.d2V(qk + eps * np.array([-2, -1, 1, 2]))
            left = (d2[1] - d2[0]) / eps
            right = (d2[3] - d2[2]) / eps
            jumps.append(abs(right - left) / scale)
    jumps = np.array(jumps)
    assert jumps.size > 20
    # generic potentials: V''' jumps by a fair fraction of its size at most knots
    assert np.median(jumps) > 0.05


def test_reproducible_with_seed():
    a = BoundedPotentialSpace(seed=31).random(12)
    b = BoundedPotentialSpace(seed=31).random(12)
    np.testing.assert_array_equal(a, b)
    c = BoundedPotentialSpace(seed=32).random(12)
    assert not np.array_equal(a, c, equal_nan=True)


def test_generator_is_used_and_advanced():
    gen = np.random.default_rng(31)
    space = BoundedPotentialSpace(seed=gen)
    assert space.rng is gen
    np.testing.assert_array_equal(space.random(12), BoundedPotentialSpace(seed=31).random(12))
    # the space drew from the caller's generator
    assert not np.array_equal(gen.random(3), np.random.default_rng(31).random(3))


def test_kth_potential_does_not_depend_on_batch_size():
    space = BoundedPotentialSpace(seed=77)
    first, second = space.random(10), space.random(10)
    both = BoundedPotentialSpace(seed=77).random(20)
    np.testing.assert_array_equal(np.concatenate([first, second]), both)
    ones = BoundedPotentialSpace(seed=77)
    np.testing.assert_array_equal(np.concatenate([ones.random(1) for _ in range(5)]), both[:5])


def _batch_at(space, feature, x, **kw):
    return space.eval_batch(feature[None, :], np.array([[x]]), **kw)[0, 0]


@pytest.mark.parametrize("dtype", [None, np.float64])
def test_eval_batch_equals_eval_one(dtype):
    space = BoundedPotentialSpace(seed=9)
    feats = space.random(6)
    xs = np.random.default_rng(0).uniform(0, 1, (40, 1))
    batch = space.eval_batch(feats, xs, dtype=dtype)
    assert batch.shape == (6, 40)
    assert batch.dtype == (np.float32 if dtype is None else np.float64)
    for k in range(6):
        one = space.eval_one(feats[k], xs, dtype=dtype)
        assert one.shape == (40,) and one.dtype == batch.dtype
        np.testing.assert_array_equal(one, batch[k])
        # DeepXDE's contract: one point gives a float (a NumPy scalar of the dtype)
        value = space.eval_one(feats[k], 0.25, dtype=dtype)
        assert np.ndim(value) == 0 and value.dtype == batch.dtype
        assert value == _batch_at(space, feats[k], 0.25, dtype=dtype)
    # the same as building the potential from its control points (float64), rounded
    exact = BoundedPotential(*space.controls(feats)).V(xs[:, 0])
    np.testing.assert_array_equal(batch, exact.astype(batch.dtype))
    np.testing.assert_array_equal(space.potentials(feats).V(xs[:, 0]), exact)  # float64


def test_n_grf_and_length_scale_ranges():
    space = BoundedPotentialSpace(seed=4, n_grf=(3, 5), length_scale=(0.05, 0.1))
    feats, scales = space.random_with_scales(300)
    assert feats.shape == (300, N_FEATURES) and scales.shape == (300,)
    assert set(feats[:, 0].astype(int)) == {3, 4, 5}
    assert np.all((scales >= 0.05) & (scales <= 0.1))
    assert scales.max() - scales.min() > 0.04  # spread over the range, not a constant
    fixed = BoundedPotentialSpace(seed=4, n_grf=(7, 7)).random(20)
    assert np.all(fixed[:, 0] == 7) and np.all(np.isfinite(fixed))
    two = BoundedPotentialSpace(seed=4, n_grf=(2, 2)).random(20)
    assert np.all(two[:, 0] == 2)
    # random() is random_with_scales()[0] on the same stream
    np.testing.assert_array_equal(
        BoundedPotentialSpace(seed=8).random(5),
        BoundedPotentialSpace(seed=8).random_with_scales(5)[0],
    )


@pytest.mark.parametrize("omega", [0.05, 0.07])
def test_control_abscissae_gaps_at_least_omega(omega):
    space = BoundedPotentialSpace(seed=12, omega=omega)
    cq, _ = space.controls(space.random(400))
    gaps = np.diff(cq, axis=1)
    gaps = gaps[np.isfinite(gaps)]
    assert gaps.min() >= omega - 1e-15
    # the cells are only shrunk by omega: gaps close to omega do occur
    assert gaps.min() < 2 * omega


def test_params_record_the_generator():
    space = BoundedPotentialSpace(seed=1, n_grf=(3, 6), length_scale=(0.02, 0.3), omega=0.04,
                                  margin=0.1)
    assert space.params() == {"n_grf": [3, 6], "length_scale": [0.02, 0.3], "omega": 0.04,
                              "margin": 0.1, "V0": V0, "L": 1.0, "draw": 2}


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_grf": (1, 3)}, "n_grf must satisfy 2 <= min <= max <= 7, got (1, 3)"),
        ({"n_grf": (5, 4)}, "n_grf must satisfy 2 <= min <= max <= 7"),
        ({"n_grf": (2, 8)}, "n_grf must satisfy 2 <= min <= max <= 7"),
        ({"length_scale": (0.0, 0.1)}, "length_scale must be 0 < min <= max, got (0.0, 0.1)"),
        ({"length_scale": (0.2, 0.1)}, "length_scale must be 0 < min <= max"),
        ({"omega": 0.0}, "omega must lie in (0, 1/(2 n_grf_max)) = (0, 0.07143)"),
        ({"omega": 1 / 14}, "omega must lie in (0, 1/(2 n_grf_max))"),
        ({"n_grf": (2, 3), "omega": 0.17}, "omega must lie in (0, 1/(2 n_grf_max)) = (0, 0.1667)"),
        ({"margin": 0.0}, "margin must lie in (0, 1), got 0.0"),
        ({"margin": 1.0}, "margin must lie in (0, 1), got 1.0"),
    ],
)
def test_bad_arguments_raise(kwargs, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        BoundedPotentialSpace(seed=0, **kwargs)


def test_wide_omega_allowed_for_few_points_and_bad_seed_type():
    space = BoundedPotentialSpace(seed=0, n_grf=(2, 3), omega=0.16)
    cq, _ = space.controls(space.random(50))
    gaps = np.diff(cq, axis=1)
    assert np.nanmin(gaps) >= 0.16 - 1e-15
    with pytest.raises(TypeError, match="seed must be an int, None or a numpy.random.Generator"):
        BoundedPotentialSpace(seed="seven")


# ----------------------------------------------------------------- DeepXDE's conventions

dde = ensure_pytorch_backend()


@contextlib.contextmanager
def _default_float(name):
    """DeepXDE's default float set to ``name`` for the block, then restored (quietly)."""
    import torch

    precision, torch_dtype = dde.config.real.precision, torch.get_default_dtype()
    with contextlib.redirect_stdout(io.StringIO()):   # DeepXDE prints the change
        dde.config.set_default_float(name)
    try:
        yield
    finally:
        {16: dde.config.real.set_float16, 32: dde.config.real.set_float32,
         64: dde.config.real.set_float64}[precision]()
        torch.set_default_dtype(torch_dtype)


def _operator_data(space, n_train, n_test):
    """DeepXDE's TripleCartesianProd from the space alone: G(V) = (V, ∫₀ˣ V) at 51 points.

    Everything goes through ``eval_batch``, in DeepXDE's default float.
    """
    from nh_operators import SENSORS

    feats = space.random(n_train + n_test)
    v = space.eval_batch(feats, SENSORS[:, None])                       # (N, 100)
    x = np.linspace(0.0, 1.0, 51)[:, None].astype(dde.config.real(np))
    at_x = space.eval_batch(feats, x)                                    # (N, 51)
    fine = np.linspace(0.0, 1.0, 2001)
    vf = space.eval_batch(feats, fine[:, None], dtype=np.float64)
    integral = np.concatenate([np.zeros((len(feats), 1)), np.cumsum(
        0.5 * (vf[:, 1:] + vf[:, :-1]) * np.diff(fine), axis=1)], axis=1)[:, ::40]
    y = np.stack([at_x, integral.astype(at_x.dtype)], axis=-1)          # (N, 51, 2)
    n = n_train
    return dde.data.TripleCartesianProd((v[:n], x), y[:n], (v[n:], x), y[n:]), v, y


@pytest.mark.parametrize("precision", ["float32", "float64"])
def test_trains_in_deepxdes_own_loop(precision):
    import torch

    import nh_operators as nh

    with _default_float(precision):
        real = dde.config.real(np)
        data, v, y = _operator_data(BoundedPotentialSpace(seed=3), 48, 16)
        assert v.dtype == y.dtype == real == np.dtype(precision)
        with torch.random.fork_rng():
            torch.manual_seed(0)
            net = nh.build_model("deeponet", preset="cpu")
        assert next(net.parameters()).dtype == dde.config.real(torch)
        model = dde.Model(data, net)
        model.compile("adam", lr=3e-3)
        # full batches: no draw from NumPy's global stream, so the numbers are fixed
        history, _ = model.train(iterations=20, display_every=20, verbose=0)
    first, last = history.loss_train[0], history.loss_train[-1]
    assert np.all(np.isfinite(last)) and np.sum(last) < 0.7 * np.sum(first)   # 0.64 → 0.35


@pytest.mark.parametrize("xs", [[-0.01, 0.5], [0.2, 1.5], [np.nan]])
def test_points_outside_the_unit_interval_raise(xs):
    space = BoundedPotentialSpace(seed=1)
    feats = space.random(2)
    bad = np.asarray(xs)[(np.asarray(xs) < 0) | (np.asarray(xs) > 1) | np.isnan(xs)]
    message = (f"the potentials live on [0, 1] and are not extrapolated; got {bad.size} "
               f"point(s) outside it, ranging from {bad.min():g} to {bad.max():g}")
    with pytest.raises(ValueError, match=re.escape(message)):
        space.eval_batch(feats, np.asarray(xs)[:, None])
    with pytest.raises(ValueError, match=re.escape(message)):
        space.eval_one(feats[0], np.asarray(xs))
    # the ends themselves are fine (V = V0 there)
    np.testing.assert_allclose(space.eval_batch(feats, np.array([[0.0], [1.0]]),
                                                dtype=np.float64), V0, rtol=0, atol=1e-13)


@pytest.fixture
def global_seed(monkeypatch):
    """Set DeepXDE's global seed (as a user would); restore every stream afterwards."""
    import random

    import torch

    monkeypatch.setattr(dde.config, "random_seed", dde.config.random_seed)
    np_state, py_state = np.random.get_state(), random.getstate()
    with torch.random.fork_rng():
        yield dde.config.set_random_seed
    np.random.set_state(np_state)
    random.setstate(py_state)


def test_seed_none_follows_deepxdes_global_seed(global_seed):
    global_seed(5)
    first = BoundedPotentialSpace().random(6)
    global_seed(5)
    second = BoundedPotentialSpace().random(6)
    np.testing.assert_array_equal(first, second)
    # the global seed s draws as seed=s does
    np.testing.assert_array_equal(first, BoundedPotentialSpace(seed=5).random(6))
    global_seed(6)
    assert not np.array_equal(BoundedPotentialSpace().random(6), first, equal_nan=True)
    # read at the first draw, as DeepXDE's spaces draw from the stream seeded then
    space = BoundedPotentialSpace()
    global_seed(5)
    np.testing.assert_array_equal(space.random(6), first)
    # an explicit seed wins over the global one
    np.testing.assert_array_equal(BoundedPotentialSpace(seed=31).random(3),
                                  BoundedPotentialSpace(seed=31).random(3))
    assert not np.array_equal(BoundedPotentialSpace(seed=31).random(6), first, equal_nan=True)


def test_seed_none_without_a_global_seed_is_fresh_entropy(monkeypatch):
    monkeypatch.setattr(dde.config, "random_seed", None)
    a, b = BoundedPotentialSpace().random(4), BoundedPotentialSpace().random(4)
    assert not np.array_equal(a, b, equal_nan=True)
