"""Tests of the named physical potentials (nh_operators.potentials.physical)."""

import numpy as np
import pytest

from nh_operators import (
    PHYSICAL_POTENTIALS,
    SENSORS,
    V0,
    AnalyticPotential,
    check_bounded,
)

NAMES = ["sho", "double_well", "morse", "mff", "smff"]
ALPHA = 20.0  # the paper's SMFF softening parameter


def _smff_scale():
    return 4.0 * np.tanh(ALPHA / 2.0) / ALPHA


def test_registry_holds_the_five_paper_potentials():
    assert sorted(PHYSICAL_POTENTIALS) == sorted(NAMES)
    for name, pot in PHYSICAL_POTENTIALS.items():
        assert isinstance(pot, AnalyticPotential)
        assert pot.name == name
        assert name in repr(pot)
    assert f"coth({ALPHA:g}" in PHYSICAL_POTENTIALS["smff"].formula


@pytest.mark.parametrize("name", NAMES)
def test_boundary_values_are_V0(name):
    pot = PHYSICAL_POTENTIALS[name]
    ends = pot.V(np.array([0.0, 1.0]))
    np.testing.assert_allclose(ends, [V0, V0], rtol=0, atol=1e-14)
    # scalars work and give 0-d results
    assert np.shape(pot.V(0.0)) == ()
    assert abs(float(pot.V(1.0)) - V0) <= 1e-14


@pytest.mark.parametrize("name", NAMES)
def test_physical_potentials_are_bounded(name):
    pot = PHYSICAL_POTENTIALS[name]
    sensors = check_bounded(pot.V, name=name)
    assert sensors.shape == (100,)
    np.testing.assert_array_equal(sensors, pot.V(SENSORS))
    inside = np.linspace(0.0, 1.0, 20001)[1:-1]
    assert np.all(pot.V(inside) < V0)


@pytest.mark.parametrize("name", NAMES)
def test_dV_matches_finite_differences(name):
    pot = PHYSICAL_POTENTIALS[name]
    rng = np.random.default_rng(11)
    q = rng.uniform(0.01, 0.99, 200)
    if name == "mff":
        q = q[np.abs(q - 0.5) > 1e-3]  # away from the kink
    h = 1e-4
    # fourth-order central difference: truncation ~h^4 V^(5) / 30, rounding ~1e-16 |V| / h
    fd = (8 * (pot.V(q + h) - pot.V(q - h)) - (pot.V(q + 2 * h) - pot.V(q - 2 * h))) / (12 * h)
    np.testing.assert_allclose(pot.dV(q), fd, rtol=1e-7, atol=1e-8)
    # also at the ends, where the slope decides whether the particle moves at all
    assert float(pot.dV(0.0)) < 0 < float(pot.dV(1.0))


def test_mff_slope_is_piecewise_constant():
    mff = PHYSICAL_POTENTIALS["mff"]
    q = np.array([0.0, 0.2, 0.4999, 0.5001, 0.8, 1.0])
    np.testing.assert_array_equal(mff.dV(q), [-4, -4, -4, 4, 4, 4])


def test_smff_series_branch_matches_high_precision():
    mpmath = pytest.importorskip("mpmath")
    smff = PHYSICAL_POTENTIALS["smff"]
    with mpmath.workdps(60):
        alpha = mpmath.mpf(ALPHA)
        scale = 4 * mpmath.tanh(alpha / 2) / alpha

        def exact(q):
            u = alpha * (mpmath.mpf(q) - mpmath.mpf(1) / 2)
            if u == 0:
                return scale, mpmath.mpf(0)
            v = scale * u * mpmath.coth(u)
            dv = scale * alpha * (mpmath.coth(u) - u / mpmath.sinh(u) ** 2)
            return v, dv

        # both sides of |u| = alpha |q - 1/2| = 0.1, where the Taylor series takes over
        edge = 0.1 / ALPHA
        offsets = np.concatenate([
            np.linspace(-2 * edge, 2 * edge, 401),
            edge * (1 + np.array([-1e-9, -1e-12, 1e-12, 1e-9])),
            -edge * (1 + np.array([-1e-9, -1e-12, 1e-12, 1e-9])),
            [1e-12, -1e-12, 1e-7],
        ])
        q = 0.5 + offsets
        ref = [exact(float(x)) for x in q]
    v_ref = np.array([float(v) for v, _ in ref])
    dv_ref = np.array([float(d) for _, d in ref])
    np.testing.assert_allclose(smff.V(q), v_ref, rtol=2e-15, atol=0)
    # the direct formula for dV cancels (coth u - u / sinh^2 u) near |u| = 0.1, so allow a
    # few hundred ulp of |dV| there; the series branch is far more accurate than that
    np.testing.assert_allclose(smff.dV(q), dv_ref, rtol=5e-14, atol=1e-18)


def _straddle(edge, towards):
    """Adjacent floats a, b with |u(a)| < 0.1 <= |u(b)|, u = alpha (q - 1/2), near edge."""
    q = edge
    inside = lambda x: abs(ALPHA * (x - 0.5)) < 0.1  # noqa: E731
    while inside(q):
        q = np.nextafter(q, towards)
    while not inside(q):
        q = np.nextafter(q, 0.5)
    return q, np.nextafter(q, towards)


def _branch_limits(u):
    """Bounds on |V_out - V_in| / |V| and |dV_out - dV_in| / |dV| one ulp apart in q across
    the series boundary |u| = 0.1, derived rather than measured:

    * each branch is a handful of correctly rounded operations plus one libm call
      (tanh, sinh: within 1 ulp), so its own rounding is at most ``ROUNDINGS`` ulps of
      each term it adds up;
    * V = s·u coth u adds no cancellation (condition 1); dV = s·α·(coth u − u / sinh² u)
      subtracts two terms of about 1/u: its relative error is the terms' rounding times
      the condition (|coth u| + |u / sinh² u|) / |coth u − u / sinh² u| (about 300 at
      u = 0.1);
    * the series stops after u^10 in u coth u (u^9 in its derivative): the first
      omitted terms are 1382 u^12 / 638512875 and 12 · 1382 u^11 / 638512875;
    * q moves by one ulp: V and dV move by |V'|·ulp(q) and |V''|·ulp(q), far below the rest.
    """
    eps = np.finfo(float).eps
    coth, frac = 1.0 / np.tanh(u), u / np.sinh(u) ** 2
    v, dv = u * coth, coth - frac
    condition = (abs(coth) + abs(frac)) / abs(dv)
    v_limit = 2 * ROUNDINGS * eps + 1382 * u**12 / 638512875 / v
    dv_limit = 2 * ROUNDINGS * eps * condition + 12 * 1382 * abs(u) ** 11 / 638512875 / abs(dv)
    return v_limit, dv_limit


#: Rounding errors, in ulps, one evaluation of a branch may carry per term.
ROUNDINGS = 4


def test_smff_is_continuous_across_the_series_boundary():
    smff = PHYSICAL_POTENTIALS["smff"]
    for edge, towards in ((0.5 + 0.1 / ALPHA, 1.0), (0.5 - 0.1 / ALPHA, 0.0)):
        inner, outer = _straddle(edge, towards)
        assert abs(ALPHA * (inner - 0.5)) < 0.1 <= abs(ALPHA * (outer - 0.5))
        # the two branches (series inside, closed form outside) must meet within the
        # error bound of _branch_limits (5e-14 relative for dV sat at rounding level,
        # 1.35e-14 against 1.33e-14 on one CPU)
        v_limit, dv_limit = _branch_limits(ALPHA * (outer - 0.5))
        assert 1e-15 < v_limit < 3e-15 and 1e-13 < dv_limit < 1e-12  # the derivation's size
        v_in, v_out = float(smff.V(inner)), float(smff.V(outer))
        d_in, d_out = float(smff.dV(inner)), float(smff.dV(outer))
        assert abs(v_out - v_in) <= v_limit * abs(v_in)
        assert abs(d_out - d_in) <= dv_limit * abs(d_in)
    # the removable singularity: V(1/2) = 4 tanh(alpha/2) / alpha, V'(1/2) = 0
    assert float(smff.V(0.5)) == pytest.approx(_smff_scale(), rel=1e-15)
    assert float(smff.dV(0.5)) == 0.0


@pytest.mark.parametrize("name", ["sho", "mff"])
def test_exact_trajectory_conserves_energy_and_satisfies_q_dot_p(name):
    pot = PHYSICAL_POTENTIALS[name]
    t = np.linspace(0.0, 6.0, 1201)
    q, p = pot.exact(t)
    assert q.shape == p.shape == t.shape
    assert q[0] == 0.0 and p[0] == 0.0
    np.testing.assert_allclose(0.5 * p**2 + pot.V(q), V0, rtol=0, atol=1e-13)
    assert np.all((q >= -1e-15) & (q <= 1 + 1e-15))
    # q' = p and p' = -V'(q) by central differences, away from the MFF kink at q = 1/2
    # (there q'' jumps, and a central difference of q' is off by ~h |jump| / 4)
    h = 1e-6
    ti, qi, pi = t[1:], q[1:], p[1:]
    away = np.abs(qi - 0.5) > 1e-3
    qp, pp = pot.exact(ti + h)
    qm, pm = pot.exact(ti - h)
    np.testing.assert_allclose(((qp - qm) / (2 * h))[away], pi[away], rtol=0, atol=1e-8)
    np.testing.assert_allclose(((pp - pm) / (2 * h))[away], -pot.dV(qi)[away], rtol=0,
                               atol=1e-7)
    # the mask removes only the points near the kink
    assert away.sum() > 0.9 * away.size


def test_exact_trajectories_known_points():
    # SHO: omega = 4, q = (1 - cos 4t) / 2 reaches q = 1 at t = pi/4; period pi/2
    q, p = PHYSICAL_POTENTIALS["sho"].exact(np.array([np.pi / 4, np.pi / 2]))
    np.testing.assert_allclose(q, [1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(p, [0.0, 0.0], atol=1e-14)
    # MFF: free fall with |force| = 4 reaches q = 1/2 at t = 1/2 (p = 2) and q = 1 at t = 1
    q, p = PHYSICAL_POTENTIALS["mff"].exact(np.array([0.5, 1.0, 1.5, 2.0, 3.0]))
    np.testing.assert_allclose(q, [0.5, 1.0, 0.5, 0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(p, [2.0, 0.0, -2.0, 0.0, 0.0], atol=1e-15)


def test_exact_keeps_the_shape_of_t():
    t = np.linspace(0, 2, 12).reshape(3, 4)
    for name in ("sho", "mff"):
        q, p = PHYSICAL_POTENTIALS[name].exact(t)
        assert q.shape == p.shape == (3, 4)
        assert q.dtype == p.dtype == np.float64


@pytest.mark.parametrize("name", ["double_well", "morse", "smff"])
def test_exact_is_none_without_closed_form(name):
    assert PHYSICAL_POTENTIALS[name].exact(np.array([0.0, 1.0])) is None
