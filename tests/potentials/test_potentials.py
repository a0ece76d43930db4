"""Tests of BoundedPotential (exact B-spline potentials) and check_bounded."""

import re

import numpy as np
import pytest
from scipy.interpolate import BSpline
from scipy.optimize import brentq

from nh_operators import SENSORS, V0, BoundedPotential, check_bounded
from nh_operators.potentials.bspline import MAX_CONTROL, clamped_knots


def _random_controls(rng, n_control):
    """Control points with 0 = q_0 < q_1 < ... < q_{C-1} = 1 and arbitrary values."""
    inner = np.sort(rng.uniform(0.05, 0.95, n_control - 2))
    while np.min(np.diff(np.concatenate([[0.0], inner, [1.0]]))) < 0.02:
        inner = np.sort(rng.uniform(0.05, 0.95, n_control - 2))
    cq = np.concatenate([[0.0], inner, [1.0]])
    cv = np.concatenate([[V0], rng.uniform(-2.0, 1.8, n_control - 2), [V0]])
    return cq, cv


class _ScipyCurve:
    """Independent evaluation: scipy BSpline curve, q(λ) inverted by brentq."""

    def __init__(self, cq, cv):
        knots = clamped_knots(len(cq))
        self.q = BSpline(knots, cq, 3)
        self.v = BSpline(knots, cv, 3)
        self.q1, self.q2 = self.q.derivative(1), self.q.derivative(2)
        self.v1, self.v2 = self.v.derivative(1), self.v.derivative(2)

    def lam(self, x):
        if x <= 0.0:
            return 0.0
        if x >= 1.0:
            return 1.0
        return brentq(lambda s: float(self.q(s)) - x, 0.0, 1.0, xtol=1e-15, rtol=1e-15,
                      maxiter=500)

    def __call__(self, xs):
        lam = np.array([self.lam(x) for x in xs])
        q1, q2 = self.q1(lam), self.q2(lam)
        v1, v2 = self.v1(lam), self.v2(lam)
        return self.v(lam), v1 / q1, (v2 * q1 - v1 * q2) / q1**3


@pytest.mark.parametrize("n_control", range(4, MAX_CONTROL + 1))
def test_values_and_derivatives_match_scipy_bspline(n_control):
    rng = np.random.default_rng(100 + n_control)
    cq, cv = _random_controls(rng, n_control)
    pot = BoundedPotential(cq, cv)
    ref = _ScipyCurve(cq, cv)
    # random points, the control abscissae, the curve's knot images and the ends
    knots_q = ref.q(np.linspace(0.0, 1.0, n_control - 2))
    x = np.concatenate([rng.uniform(0.0, 1.0, 60), cq, knots_q, [1e-12, 1 - 1e-12]])
    V, dV, d2V = ref(x)
    # λ is found to ~1e-15; V, V' and V'' then agree to that times their own slope
    np.testing.assert_allclose(pot.V(x), V, rtol=0, atol=1e-13 * (1 + np.abs(V).max()))
    np.testing.assert_allclose(pot.dV(x), dV, rtol=0, atol=1e-12 * (1 + np.abs(dV).max()))
    np.testing.assert_allclose(pot.d2V(x), d2V, rtol=0, atol=1e-11 * (1 + np.abs(d2V).max()))


def test_end_values_and_slopes_are_those_of_the_control_polygon():
    rng = np.random.default_rng(7)
    for n_control in range(4, MAX_CONTROL + 1):
        cq, cv = _random_controls(rng, n_control)
        pot = BoundedPotential(cq, cv)
        assert float(pot.V(0.0)) == pytest.approx(cv[0], abs=1e-15)
        assert float(pot.V(1.0)) == pytest.approx(cv[-1], abs=1e-14)
        # a clamped B-spline leaves its ends along the first and last control legs
        assert float(pot.dV(0.0)) == pytest.approx((cv[1] - cv[0]) / cq[1], rel=1e-12)
        assert float(pot.dV(1.0)) == pytest.approx((cv[-1] - cv[-2]) / (1 - cq[-2]), rel=1e-12)


def test_straight_control_polygon_gives_a_straight_line():
    # control points on a line: the curve is that line and V is linear in q
    cq = np.array([0.0, 0.2, 0.45, 0.7, 1.0])
    cv = 2.0 - 3.0 * cq
    pot = BoundedPotential(cq, cv)
    x = np.linspace(0.0, 1.0, 101)
    np.testing.assert_allclose(pot.V(x), 2.0 - 3.0 * x, rtol=0, atol=1e-14)
    np.testing.assert_allclose(pot.dV(x), -3.0, rtol=0, atol=1e-12)
    np.testing.assert_allclose(pot.d2V(x), 0.0, rtol=0, atol=1e-10)


def test_force_outside_the_interval_continues_then_is_held():
    # a stage that overshoots a turning point sees the end piece continued smoothly;
    # beyond OUTSIDE_MARGIN the force is held at its end value
    from nh_operators.potentials._spline_kernels import OUTSIDE_MARGIN

    pot = BoundedPotential([0, 0.2, 0.5, 0.8, 1], [2, -1, 1.5, -2, 2])
    for end, sign in ((0.0, -1.0), (1.0, 1.0)):
        dx = sign * 1e-4
        taylor = pot.dV(end) + pot.d2V(end) * dx
        assert float(pot.dV(end + dx)) == pytest.approx(float(taylor), abs=1e-5)
        far = end + sign * np.array([OUTSIDE_MARGIN + 1e-9, 0.3])
        np.testing.assert_array_equal(pot.dV(far), np.full(2, pot.dV(end)))
    assert float(pot.dV(0.0)) == pytest.approx(-3 / 0.2, rel=1e-12)
    assert float(pot.dV(1.0)) == pytest.approx(4 / 0.2, rel=1e-12)


def test_shapes_single_and_batch():
    rng = np.random.default_rng(3)
    single = BoundedPotential(*_random_controls(rng, 6))
    assert not single.batched
    with pytest.raises(TypeError, match="no len"):
        len(single)
    assert np.shape(single.V(0.3)) == ()
    assert single.V(np.zeros((3, 4))).shape == (3, 4)
    assert single.dV(np.zeros(7)).shape == (7,)
    assert single.d2V(np.zeros((2, 5))).shape == (2, 5)

    controls = [_random_controls(rng, c) for c in (4, 9, 6)]
    cq = np.full((3, MAX_CONTROL), np.nan)
    cv = np.full((3, MAX_CONTROL), np.nan)
    for i, (q, v) in enumerate(controls):
        cq[i, : len(q)] = q
        cv[i, : len(v)] = v
    batch = BoundedPotential(cq, cv)
    assert batch.batched and len(batch) == 3
    assert batch.V(0.3).shape == (3,)
    assert batch.V(np.zeros((2, 5))).shape == (3, 2, 5)
    assert batch.d2V(np.zeros(7)).shape == (3, 7)


def test_batch_and_single_indexing_agree():
    rng = np.random.default_rng(4)
    counts = (4, 9, 6, 5, 7)
    cq = np.full((len(counts), MAX_CONTROL), np.nan)
    cv = np.full((len(counts), MAX_CONTROL), np.nan)
    singles = []
    for i, c in enumerate(counts):
        q, v = _random_controls(rng, c)
        cq[i, :c], cv[i, :c] = q, v
        singles.append(BoundedPotential(q, v))
    batch = BoundedPotential(cq, cv)
    x = rng.uniform(0, 1, (4, 6))
    for i, single in enumerate(singles):
        for f in ("V", "dV", "d2V"):
            expect = getattr(single, f)(x)
            np.testing.assert_array_equal(getattr(batch, f)(x)[i], expect)
            np.testing.assert_array_equal(getattr(batch[i], f)(x), expect)
        assert not batch[i].batched
        np.testing.assert_array_equal(batch[i].control_q[0, : counts[i]], cq[i, : counts[i]])
    sub = batch[1:4]
    assert sub.batched and len(sub) == 3
    np.testing.assert_array_equal(sub.V(x), batch.V(x)[1:4])
    picked = batch[np.array([4, 0])]
    np.testing.assert_array_equal(picked.dV(x), batch.dV(x)[[4, 0]])


def test_float32_and_list_inputs_are_accepted():
    pot = BoundedPotential([0, 0.3, 0.7, 1], [2, -2, 1, 2])
    x64 = np.array([0.1, 0.5, 0.9])
    np.testing.assert_array_equal(pot.V(x64.tolist()), pot.V(x64))
    np.testing.assert_array_equal(pot.V(x64.astype(np.float32)),
                                  pot.V(x64.astype(np.float32).astype(np.float64)))


@pytest.mark.parametrize(
    ("cq", "cv", "message"),
    [
        ([0, 0.5, 0.7, 1], [2, 1, 2], "control_q and control_V must have the same shape"),
        (np.zeros((1, 2, 4)), np.zeros((1, 2, 4)), "must have the same shape"),
        ([0, 0.5, 1], [2, 1, 2], "need 4 to 9 control points, got 3"),
        (np.linspace(0, 1, 10), np.full(10, 1.0), "need 4 to 9 control points, got 10"),
        ([0.1, 0.4, 0.7, 1], [2, 1, 1, 2], "must start at 0, end at 1 and strictly increase"),
        ([0, 0.4, 0.7, 0.9], [2, 1, 1, 2], "must start at 0, end at 1 and strictly increase"),
        ([0, 0.7, 0.4, 1], [2, 1, 1, 2], "must start at 0, end at 1 and strictly increase"),
        ([0, 0.4, 0.4, 1], [2, 1, 1, 2], "must start at 0, end at 1 and strictly increase"),
        ([0, 0.4, 0.7, 1], [2, np.nan, 1, 2], "control points must be finite, at least 4"),
        ([0, 0.4, 0.7, 1], [2, np.inf, 1, 2], "control points must be finite, at least 4"),
        ([0, np.nan, 0.4, 0.7, 1], [2, 1, 1, 1, 2], "control points must be finite"),
    ],
)
def test_bad_control_points_raise(cq, cv, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        BoundedPotential(cq, cv)


def test_bad_row_of_a_batch_is_named():
    cq = np.array([[0, 0.3, 0.6, 1.0], [0, 0.6, 0.3, 1.0]])
    cv = np.array([[2, 1, 1, 2.0], [2, 1, 1, 2.0]])
    with pytest.raises(ValueError, match=re.escape("strictly increase (potential 1)")):
        BoundedPotential(cq, cv)
    short = np.array([[0, 0.3, 0.6, 1.0, np.nan], [0, 1.0, np.nan, np.nan, np.nan]])
    with pytest.raises(ValueError, match=re.escape("at least 4 of them (potential 1)")):
        BoundedPotential(short, short)


# ------------------------------------------------------------------ check_bounded


def _sho(q):
    return 8.0 * (np.asarray(q) - 0.5) ** 2


def test_check_bounded_good_inputs_return_sensor_values():
    out = check_bounded(_sho)
    assert out.shape == (100,) and out.dtype == np.float64
    np.testing.assert_array_equal(out, _sho(SENSORS))
    values = _sho(SENSORS)
    np.testing.assert_array_equal(check_bounded(values), values)
    batch = np.stack([values, 2.0 - np.sin(np.pi * SENSORS)])
    out = check_bounded(batch.tolist())
    assert out.shape == (2, 100)
    np.testing.assert_array_equal(out, batch)
    # a bounded potential's own V, as a callable
    pot = BoundedPotential([0, 0.3, 0.7, 1], [2, -2, 1, 2])
    np.testing.assert_array_equal(check_bounded(pot.V), pot.V(SENSORS))


@pytest.mark.parametrize("shape", [(99,), (101,), (2, 99), (100, 1), (1, 1, 100), ()])
def test_check_bounded_wrong_length(shape):
    with pytest.raises(ValueError, match=re.escape(f"got shape {shape}")) as info:
        check_bounded(np.ones(shape))
    assert "must hold the values at the 100 SENSORS" in str(info.value)


def test_check_bounded_non_finite_names_q():
    values = _sho(SENSORS)
    values[37] = np.nan
    with pytest.raises(ValueError, match=re.escape(f"V is not finite at q = {SENSORS[37]:.6g}")):
        check_bounded(values)
    values[37] = np.inf
    with pytest.raises(ValueError, match="not finite"):
        check_bounded(values, name="W")
    # a callable: the first of the 1001 check points (and sensors) above 0.7005 is 0.701
    with pytest.raises(ValueError, match=re.escape("V is not finite at q = 0.701 (nan)")):
        check_bounded(lambda q: np.where(q > 0.7005, np.nan, _sho(q)))


@pytest.mark.parametrize("end", [0, 1])
def test_check_bounded_end_values(end):
    values = _sho(SENSORS)
    values[-end] = 2.5
    with pytest.raises(ValueError, match=re.escape(f"V({end}) = 2.5, but a bounded potential")):
        check_bounded(values)

    def shifted(q):
        return _sho(q) + (0.1 * q if end else 0.1 * (1 - q))

    with pytest.raises(ValueError, match=re.escape(f"potential({end}) = 2.1")):
        check_bounded(shifted, name="potential")


def test_check_bounded_end_tolerance():
    values = _sho(SENSORS)
    values[0] = V0 + 1e-9
    np.testing.assert_array_equal(check_bounded(values), values)  # default atol 1e-8
    with pytest.raises(ValueError, match=re.escape("V(0) = 2.000000001")):
        check_bounded(values, atol=1e-10)


def test_check_bounded_interior_names_where_it_fails():
    values = _sho(SENSORS)
    values[63] = V0
    expected = f"V ≥ V0 = 2 inside (0, 1): V({SENSORS[63]:.6g}) = 2"
    with pytest.raises(ValueError, match=re.escape(expected)):
        check_bounded(values)
    # a callable above V0 on (0.2504, 0.2996): the first check point there is 0.251
    # (the grid is linspace(0, 1, 1001) joined with the sensors; 25/99 = 0.2525)
    bump = lambda q: np.where((q > 0.2504) & (q < 0.2996), 2.5, _sho(q))  # noqa: E731
    with pytest.raises(ValueError, match=re.escape("V(0.251) = 2.5; a bounded potential")):
        check_bounded(bump)
    # too narrow for the 1001 check points: not seen
    narrow = lambda q: np.where((q > 0.25011) & (q < 0.25019), 2.5, _sho(q))  # noqa: E731
    assert check_bounded(narrow).shape == (100,)


def test_check_bounded_batch_names_the_row():
    batch = np.stack([_sho(SENSORS)] * 3)
    batch[2, 50] = 3.0
    with pytest.raises(ValueError, match=re.escape("V[2] ≥ V0")):
        check_bounded(batch)
    batch[1, 0] = 0.0
    with pytest.raises(ValueError, match=re.escape("V[1](0) = 0")):
        check_bounded(batch)
    batch[0, 7] = np.nan  # the first failing row is named, whatever its fault
    with pytest.raises(ValueError, match=re.escape("V[0] is not finite at q = 0.0707071")):
        check_bounded(batch)


def test_newton_stops_early_but_finds_the_same_point():
    # bspline_locate stops after a Newton step of 4 ulps (about 4 evaluations instead
    # of 8-14); V and V' must still agree with the independent brentq inversion at many
    # points
    rng = np.random.default_rng(7)
    for n_control in (4, 6, MAX_CONTROL):
        cq, cv = _random_controls(rng, n_control)
        pot, ref = BoundedPotential(cq, cv), _ScipyCurve(cq, cv)
        x = rng.uniform(0.0, 1.0, 400)
        V, dV, _ = ref(x)
        np.testing.assert_allclose(pot.V(x), V, rtol=0, atol=2e-14 * (1 + np.abs(V).max()))
        np.testing.assert_allclose(pot.dV(x), dV, rtol=0, atol=2e-13 * (1 + np.abs(dV).max()))
