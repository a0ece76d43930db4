"""predict on a query-coupled network: run on the training grid, then interpolate."""

import re
import warnings

import numpy as np
import pytest
import torch
from scipy.interpolate import CubicSpline

import nh_operators as nh
from nh_operators.models.inference import interpolate_grid


@pytest.fixture(scope="module")
def shipped():
    """The shipped mambonet-paper network (its decoder couples the query times)."""
    net = nh.pretrained("mambonet-paper").net
    assert net.query_coupled is True
    return net


@pytest.fixture(scope="module")
def V():
    space = nh.BoundedPotentialSpace(seed=2031)
    return space.potentials(space.random(5)).V(nh.SENSORS)   # (5, 100) float64


def _raw(net, V, t):
    """The network's own output at t, in one forward, as float64 (q, p)."""
    param = next(net.parameters())
    with torch.no_grad():
        y = net((torch.as_tensor(V, dtype=param.dtype),
                 torch.as_tensor(np.array(t)[:, None], dtype=param.dtype)))
    y = y.double().numpy()
    return y[..., 0], y[..., 1]


def test_grid_call_is_the_networks_output_bit_for_bit(shipped, V):
    q, p = nh.predict(shipped, V, nh.TIMES)
    q_raw, p_raw = _raw(shipped, V, nh.TIMES)
    np.testing.assert_array_equal(q, q_raw)
    np.testing.assert_array_equal(p, p_raw)


def test_a_time_asked_alone_gives_the_grids_answer(shipped, V):
    q_grid, p_grid = nh.predict(shipped, V, nh.TIMES)
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # the old warning is gone
        q50, p50 = nh.predict(shipped, V, nh.TIMES[[50]])
    # a grid time: the spline through the grid values passes through them
    np.testing.assert_allclose(q50[:, 0], q_grid[:, 50], rtol=0, atol=1e-13)
    np.testing.assert_allclose(p50[:, 0], p_grid[:, 50], rtol=0, atol=1e-13)
    # the coupled answer, which predict used to return, is far from it (issue 39: 0.22)
    q_coupled, _ = _raw(shipped, V, nh.TIMES[[50]])
    assert np.abs(q_coupled[:, 0] - q_grid[:, 50]).mean() > 0.02


def test_off_grid_times_are_the_not_a_knot_spline_of_the_grid(shipped, V):
    q_grid, p_grid = nh.predict(shipped, V, nh.TIMES)
    t = np.array([0.0, 0.013, 0.5, 1.0101, 1.77, 2.0])
    q, p = nh.predict(shipped, V, t)
    # an independent construction: scipy's spline of each row on its own
    for k in range(len(V)):
        np.testing.assert_allclose(q[k], CubicSpline(nh.TIMES, q_grid[k])(t), rtol=0,
                                   atol=1e-13)
        np.testing.assert_allclose(p[k], CubicSpline(nh.TIMES, p_grid[k])(t), rtol=0,
                                   atol=1e-13)
    np.testing.assert_array_equal(q[:, 0], q_grid[:, 0])   # a knot: the value itself
    np.testing.assert_allclose(q[:, -1], q_grid[:, -1], rtol=0, atol=1e-15)


def test_the_answer_does_not_depend_on_the_other_times(shipped, V):
    t = np.array([0.05, 0.7311, 1.4, 1.99])
    q_all, p_all = nh.predict(shipped, V, t)
    for i, ti in enumerate(t):
        q, p = nh.predict(shipped, V, [ti])
        np.testing.assert_array_equal(q[:, 0], q_all[:, i])
        np.testing.assert_array_equal(p[:, 0], p_all[:, i])
    # in another order, with repeats, among grid times, or one potential alone
    q_mix, _ = nh.predict(shipped, V, np.concatenate([nh.TIMES[:3], t[::-1], t[:1]]))
    np.testing.assert_array_equal(q_mix[:, 3:7], q_all[:, ::-1])
    np.testing.assert_array_equal(q_mix[:, 7], q_all[:, 0])
    q_one, _ = nh.predict(shipped, V[2], t, batch_size=1)
    np.testing.assert_allclose(q_one, q_all[2], rtol=0, atol=1e-6)   # float32 batching


def test_the_neural_method_goes_through_predict(shipped, V):
    method = nh.pretrained("mambonet-paper")
    t = np.array([0.3, 1.1])
    q, p = method(V, t)
    q_ref, p_ref = nh.predict(shipped, V, t)
    np.testing.assert_array_equal(q, q_ref)
    np.testing.assert_array_equal(p, p_ref)
    q_alone, _ = method(V, t[1:])
    np.testing.assert_array_equal(q_alone[:, 0], q[:, 1])


@pytest.mark.parametrize("bad", [[-0.01, 1.0], [0.5, 2.001], [3.0]])
def test_times_outside_the_grid_raise(shipped, V, bad):
    lo, hi = min(bad), max(bad)
    message = (f"MambONet couples its query times, so it is run on its training grid "
               f"nh_operators.TIMES and interpolated: times must lie in the grid's range "
               f"[0, 2], got t from {lo:g} to {hi:g}")
    with pytest.raises(ValueError, match=re.escape(message)):
        nh.predict(shipped, V, bad)


def test_uncoupled_networks_are_still_asked_directly():
    torch.manual_seed(0)
    net = nh.build_model("deeponet", preset="cpu")
    assert not getattr(net, "query_coupled", False)
    V = 2 - 8 * nh.SENSORS * (1 - nh.SENSORS)
    t = np.array([0.25, 2.5])   # beyond the grid: asked directly, no error
    q, p = nh.predict(net, V, t)
    q_raw, p_raw = _raw(net, V[None], t)
    np.testing.assert_array_equal(q, q_raw[0])
    np.testing.assert_array_equal(p, p_raw[0])


def test_interpolate_grid_is_exact_on_cubics_and_checks_its_input():
    y = np.stack([1 - 2 * nh.TIMES + nh.TIMES**3, 0.5 * nh.TIMES**2])   # (2, 100)
    t = np.array([0.0, 0.123, 1.5, 2.0])
    out = interpolate_grid(y, t)
    np.testing.assert_allclose(out, np.stack([1 - 2 * t + t**3, 0.5 * t**2]), rtol=0,
                               atol=1e-13)
    assert out.dtype == np.float64
    # rounding just past the ends is clamped, not extrapolated
    np.testing.assert_array_equal(interpolate_grid(y, [2.0 + 5e-13]), interpolate_grid(y, [2.0]))
    with pytest.raises(ValueError, match=re.escape("must have 100 grid times along axis -1, "
                                                   "got shape (2, 99)")):
        interpolate_grid(y[:, :99], t)
    with pytest.raises(ValueError, match=re.escape("range [0, 2], got t from -1 to 0.5")):
        interpolate_grid(y, [-1.0, 0.5])
