"""Physics-informed training data: residuals of Hamilton's equations, exact checks."""

import numpy as np
import pytest
import torch
from scipy.interpolate import CubicSpline

import nh_operators as nh
from nh_operators._backend import ensure_pytorch_backend
from nh_operators.data import (OperatorData, PhysicsTerms, SensorSpline, integral_residuals,
                               state_transform, time_derivative)

dde = ensure_pytorch_backend()


def test_sensor_spline_matches_scipy_and_reproduces_cubics():
    x = np.linspace(0, 1, 100)
    rng = np.random.default_rng(0)
    V = rng.normal(size=(3, 100))
    q = rng.uniform(-0.05, 1.05, (3, 40))
    v, dv = SensorSpline(x)(torch.tensor(V), torch.tensor(q))
    for row in range(3):
        ref = CubicSpline(x, V[row])
        np.testing.assert_allclose(v[row].numpy(), ref(q[row]), rtol=0, atol=1e-9)
        np.testing.assert_allclose(dv[row].numpy(), ref(q[row], 1), rtol=0, atol=1e-7)
    cubic = 2 - 3 * x + x**2 - 4 * x**3  # not-a-knot: exact for a cubic, also outside
    v, dv = SensorSpline(x)(torch.tensor(cubic[None]), torch.tensor([[0.123, 0.5, 1.02]],
                                                                  dtype=torch.float64))
    qs = np.array([0.123, 0.5, 1.02])
    np.testing.assert_allclose(v[0].numpy(), 2 - 3 * qs + qs**2 - 4 * qs**3, atol=1e-12)
    np.testing.assert_allclose(dv[0].numpy(), -3 + 2 * qs - 12 * qs**2, atol=1e-10)


def test_sensor_spline_errors_are_named():
    with pytest.raises(ValueError, match="at least 4 knots"):
        SensorSpline(np.linspace(0, 1, 3))
    with pytest.raises(ValueError, match="uniformly spaced"):
        SensorSpline(np.array([0.0, 0.1, 0.3, 0.4]))
    with pytest.raises(ValueError, match=r"V must be \(B, 5\)"):
        SensorSpline(np.linspace(0, 1, 5))(torch.zeros(2, 4), torch.zeros(2, 3))


def _tiny_deeponet():
    torch.manual_seed(0)
    return nh.build_model("deeponet", "cpu", hidden_size=16, hidden_layers=2,
                          branches=4).double()


def test_time_derivative_is_the_pointwise_derivative_of_every_row():
    net = _tiny_deeponet()
    V = torch.tensor(np.random.default_rng(1).normal(size=(3, 100)))
    t = torch.linspace(0, 2, 7, dtype=torch.float64)[:, None].requires_grad_()
    y = net((V, t))
    dy = time_derivative(y, t)
    for b in range(3):  # one autograd pass per row and output, as DeepXDE would
        for k in range(2):
            (g,) = torch.autograd.grad(y[b, :, k].sum(), t, retain_graph=True)
            np.testing.assert_allclose(dy[b, :, k].detach().numpy(), g[:, 0].numpy(),
                                       rtol=1e-12, atol=1e-12)
    h = 1e-6  # and central differences of the forward
    with torch.no_grad():
        fd = (net((V, t + h)) - net((V, t - h))) / (2 * h)
    np.testing.assert_allclose(dy.detach().numpy(), fd.numpy(), rtol=1e-6, atol=1e-8)
    with pytest.raises(ValueError, match="require grad"):
        time_derivative(y, t.detach())


def test_state_transform_makes_the_state_exact():
    net = _tiny_deeponet()
    net.apply_output_transform(state_transform(100))
    t = torch.tensor([[0.0], [0.7]], dtype=torch.float64)
    y = net((torch.randn(4, 100, dtype=torch.float64), t))
    assert torch.equal(y[:, 0], torch.zeros(4, 2, dtype=torch.float64))
    assert torch.all(y[:, 1] != 0)


def _sho_inputs(t_values, q0=0.0, energy_shift=0.0):
    """SHO V = 8 (q − 1/2)² from rest at q0: q = 1/2 + (q0 − 1/2) cos 4t, p = dq/dt."""
    sensors = 8 * (nh.SENSORS - 0.5) ** 2
    V = torch.tensor(np.concatenate([sensors, [q0, 0.0]])[None])
    t = torch.tensor(t_values[:, None]).requires_grad_()
    a = q0 - 0.5
    q = 0.5 + a * torch.cos(4 * t[:, 0]) + energy_shift
    p = -4 * a * torch.sin(4 * t[:, 0])
    return (V, t), torch.stack([q, p], dim=-1)[None]


def test_exact_trajectory_has_zero_residual_and_energy_drift():
    terms = PhysicsTerms(energy=1.0)
    inputs, y = _sho_inputs(np.linspace(0, 2, 50), q0=0.1)
    rq, rp, energy, labels = (c.detach() for c in terms.losses(inputs, y, None))
    assert float(rq) < 1e-26 and float(rp) < 1e-20 and float(energy) < 1e-24
    assert float(labels) == 0.0
    # a shifted position: r_q = 0, r_p = V'(q + s) − V'(q) = 16 s exactly, drift known
    inputs, y = _sho_inputs(np.linspace(0, 2, 50), q0=0.1, energy_shift=0.01)
    rq, rp, energy, _ = (c.detach() for c in terms.losses(inputs, y, None))
    assert float(rq) < 1e-26
    np.testing.assert_allclose(float(rp), 0.16**2, rtol=1e-10)
    q = y[0, :, 0].detach().numpy()
    drift = 8 * (q - 0.5) ** 2 - 8 * (q - 0.01 - 0.5) ** 2
    np.testing.assert_allclose(float(energy), np.mean(drift**2), rtol=1e-9)


def test_labels_count_only_on_labelled_rows_and_the_weights_apply():
    inputs, y = _sho_inputs(np.linspace(0, 2, 10))
    V, t = inputs
    V, y = V.expand(2, -1), y.expand(2, -1, -1)
    targets = y.detach().clone() + 0.5
    targets[1] = float("nan")  # row 1 unlabelled
    cols = [c.detach() for c in PhysicsTerms(residual=3.0, labels=2.0).losses((V, t), y,
                                                                            targets)]
    np.testing.assert_allclose(float(cols[3]), 2.0 * 0.25, rtol=1e-12)
    assert float(cols[2]) == 0.0  # energy weight 0


def test_causal_weights_discount_times_after_a_large_residual():
    terms = PhysicsTerms(causal=10.0)
    r2 = torch.tensor([[0.0, 1.0, 0.0, 0.0]])
    t = torch.tensor([[0.0], [0.5], [1.0], [1.5]])
    w = terms._causal_weights(r2, t)
    np.testing.assert_allclose(w.numpy(), [[1.0, 1.0, np.exp(-5.0), np.exp(-5.0)]],
                               rtol=1e-6)


def test_physics_terms_errors_and_labelled_rows():
    with pytest.raises(ValueError, match="label_fraction"):
        PhysicsTerms(label_fraction=1.5)
    with pytest.raises(ValueError, match="energy must be non-negative"):
        PhysicsTerms(energy=-1)
    with pytest.raises(ValueError, match="extra_times"):
        PhysicsTerms(extra_times=2.5)
    mask = PhysicsTerms(label_fraction=0.1, seed=3).labelled(1000)
    assert mask.sum() == 100
    assert np.array_equal(mask, PhysicsTerms(label_fraction=0.1, seed=3).labelled(1000))


@pytest.mark.parametrize("terms", [PhysicsTerms(extra_times=20), PhysicsTerms(form="integral")],
                         ids=["derivative", "integral"])
def test_physics_only_training_lowers_the_residual_without_labels(terms):
    space = nh.BoundedPotentialSpace(seed=0)
    pots = space.potentials(space.random(64))
    V = pots.V(nh.SENSORS).astype(np.float32)
    t = nh.TIMES[:, None].astype(np.float32)
    y = np.zeros((64, 100, 2), np.float32)  # never read: label_fraction 0
    data = OperatorData((V[:48], t), y[:48], (V[48:], t), y[48:],
                        physics=terms)
    assert np.isnan(data.train_y).all()
    torch.manual_seed(0)
    net = nh.build_model("deeponet", "cpu", hidden_size=32, hidden_layers=2, branches=8)
    net.apply_output_transform(state_transform(100))
    model = dde.Model(data, net)
    model.compile("adam", lr=2e-3)
    losses, _ = model.train(iterations=150, batch_size=16, display_every=1000, verbose=0)
    first, last = np.sum(losses.loss_train[0][:2]), np.sum(losses.loss_train[-1][:2])
    assert last < 0.2 * first, (first, last)


def test_curriculum_counts_only_the_times_inside_its_horizon():
    """A trajectory exact up to t = 1 and wrong after: no residual while the horizon is
    inside [0, 1], the full one once it has widened to 2."""
    t_values = np.linspace(0, 2, 41)
    inputs, y = _sho_inputs(t_values)
    late = torch.tensor(t_values > 1.0)[None, :, None]
    y = torch.where(late, y + 0.3 * (inputs[1][:, :1] - 1.0) ** 2, y)  # C¹ at t = 1
    terms = PhysicsTerms(curriculum=100)
    assert terms.horizon(0) == 0.25 and terms.horizon(100) == 2.0 == terms.horizon(10**6)
    early = [float(c.detach()) for c in terms.losses(inputs, y, None, iteration=40)[:2]]
    assert terms.horizon(40) == pytest.approx(0.95)
    assert max(early) < 1e-20
    full = [float(c.detach()) for c in terms.losses(inputs, y, None, iteration=100)[:2]]
    plain = [float(c.detach()) for c in PhysicsTerms().losses(inputs, y, None)[:2]]
    assert full == pytest.approx(plain, rel=1e-12) and full[0] > 1e-3
    with pytest.raises(ValueError, match="curriculum must be a non-negative integer"):
        PhysicsTerms(curriculum=-1)


def test_integral_residual_of_the_exact_trajectory_converges_at_second_order():
    """The trapezoid rule's error on the exact SHO trajectory: O(Δt²), so the mean
    squared residual falls 16x per halving of the spacing."""
    terms = PhysicsTerms(form="integral", energy=1.0)
    cols = []
    for n in (51, 101, 201):
        inputs, y = _sho_inputs(np.linspace(0, 2, n), q0=0.1)
        cols.append([float(c.detach()) for c in terms.losses(inputs, y, None)])
    rq = np.array([c[0] for c in cols])
    rp = np.array([c[1] for c in cols])
    assert rq[0] < 1e-6 and rp[0] < 1e-4 and max(c[2] for c in cols) < 1e-24
    np.testing.assert_allclose(rq[:-1] / rq[1:], 16.0, rtol=0.05)
    np.testing.assert_allclose(rp[:-1] / rp[1:], 16.0, rtol=0.05)


def test_integral_residual_of_a_shifted_trajectory_is_known_exactly():
    """q shifted by s (the start missed by s), p unchanged: r_q grows by s at every time
    and r_p by −∫ (F(q + s) − F(q)) = 16 s t, exactly (the trapezoid rule is exact on
    constants); the loss columns are the means of their squares."""
    t_values = np.linspace(0, 2, 201)
    terms = PhysicsTerms(form="integral")
    one = torch.ones(1, 1, dtype=torch.float64)
    start = (0.1 * one, 0 * one, -16 * (0.1 - 0.5) * one)
    res = []
    for shift in (0.0, 0.01):
        inputs, y = _sho_inputs(t_values, q0=0.1, energy_shift=shift)
        q, p = y[..., 0], y[..., 1]
        res.append(integral_residuals(q, p, -16 * (q - 0.5), start, inputs[1]))
        cols = [float(c.detach()) for c in terms.losses(inputs, y, None)]
        means = [float(torch.mean(r.detach() ** 2)) for r in res[-1]]
        np.testing.assert_allclose(cols[:2], means, rtol=1e-9)  # spline: F to rounding
    (rq0, rp0), (rq1, rp1) = res
    np.testing.assert_allclose((rq1 - rq0).detach().numpy()[0], 0.01, rtol=0, atol=1e-15)
    np.testing.assert_allclose((rp1 - rp0).detach().numpy()[0], 0.16 * t_values, rtol=0,
                               atol=1e-13)


def test_integral_residuals_take_times_in_any_order():
    t_sorted = np.linspace(0, 2, 41)
    perm = np.random.default_rng(0).permutation(41)
    t_values = np.concatenate([t_sorted[perm], t_sorted[:3]])  # shuffled, with repeats
    inputs, y = _sho_inputs(t_values, q0=0.2)
    q, p = y[..., 0], y[..., 1]
    F = -16 * (q - 0.5)
    one = torch.ones(1, 1, dtype=torch.float64)
    start = (0.2 * one, 0 * one, -16 * (0.2 - 0.5) * one)
    rq, rp = integral_residuals(q, p, F, start, inputs[1])
    inputs_s, y_s = _sho_inputs(t_sorted, q0=0.2)
    rq_s, rp_s = integral_residuals(y_s[..., 0], y_s[..., 1], -16 * (y_s[..., 0] - 0.5),
                                    start, inputs_s[1])
    np.testing.assert_allclose(rq[0, :41].detach().numpy(), rq_s[0, perm].detach().numpy(),
                               rtol=0, atol=1e-15)
    np.testing.assert_allclose(rp[0, 41:].detach().numpy(), rp_s[0, :3].detach().numpy(),
                               rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="form must be one of"):
        PhysicsTerms(form="weak")
