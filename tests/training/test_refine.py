"""Test-time refinement (nh.refine) on the harmonic oscillator, where everything is exact.

V = 8 (q − 1/2)², released at rest from q = 0: q(t) = (1 − cos 4t)/2, p(t) = 2 sin 4t.
The "network" below is that trajectory plus a·t in both outputs, with a trainable a, so
the residuals are known in closed form: dq/dt − p = a (1 − t), dp/dt + V'(q) = a (1 + 16 t).
"""

import numpy as np
import pytest
import torch

import nh_operators as nh
from nh_operators.training import Refinement, refine

SHO = nh.PHYSICAL_POTENTIALS["sho"]


class ExactPlusDrift(torch.nn.Module):
    """(q, p) = exact SHO trajectory + a·t, and b·t more in p; pointwise in t."""

    query_coupled = False

    def __init__(self, a: float, b: float = 0.0) -> None:
        super().__init__()
        self.a = torch.nn.Parameter(torch.tensor(a, dtype=torch.float32))
        self.b = torch.nn.Parameter(torch.tensor(b, dtype=torch.float32))

    def forward(self, inputs):
        V, t = inputs
        t = t[:, 0].to(self.a.dtype)
        q = 0.5 * (1 - torch.cos(4 * t)) + self.a * t
        p = 2 * torch.sin(4 * t) + (self.a + self.b) * t
        return torch.stack([q, p], dim=-1)[None].expand(len(V), -1, -1)


def exact_residual(a, collocation=200, end=2.0):
    t = np.linspace(0.0, end, collocation)
    return 0.5 * a**2 * (np.mean((1 - t) ** 2) + np.mean((1 + 16 * t) ** 2))


def test_residual_before_is_the_closed_form_and_steps_zero_only_evaluates():
    net = ExactPlusDrift(0.01)
    r = refine(net, SHO, steps=0)
    assert isinstance(r, Refinement) and r.steps == 0
    # V' from a spline of 1,000 samples of a quadratic: exact up to rounding
    np.testing.assert_allclose(r.residual_before, exact_residual(0.01), rtol=1e-5)
    assert r.residual_after == pytest.approx(r.residual_before, rel=1e-12)
    t = nh.TIMES
    np.testing.assert_allclose(r.q, 0.5 * (1 - np.cos(4 * t)) + 0.01 * t, atol=1e-6)
    np.testing.assert_allclose(r.p, 2 * np.sin(4 * t) + 0.01 * t, atol=1e-6)


def test_refinement_removes_the_drift_and_leaves_the_given_network_alone():
    net = ExactPlusDrift(0.05)
    r = refine(net, SHO, steps=3, optimizer="lbfgs")
    assert r.residual_before == pytest.approx(exact_residual(0.05), rel=1e-5)
    assert r.residual_after < 1e-12 * r.residual_before / exact_residual(0.05) + 1e-14
    assert abs(float(r.net.a.detach())) < 1e-7 and r.net.a.dtype == torch.float64
    assert float(net.a.detach()) == pytest.approx(0.05) and net.a.dtype == torch.float32
    t = nh.TIMES
    np.testing.assert_allclose(r.q, 0.5 * (1 - np.cos(4 * t)), atol=1e-7)
    np.testing.assert_allclose(r.p, 2 * np.sin(4 * t), atol=1e-7)


def test_adam_lowers_the_residual_step_by_step():
    net = ExactPlusDrift(0.05)
    few, more = (refine(net, SHO, steps=s, lr=1e-3) for s in (5, 20))
    assert exact_residual(0.05) > few.residual_after > more.residual_after
    # Adam moves a by about lr per step while the gradient keeps its sign
    assert float(few.net.a.detach()) == pytest.approx(0.05 - 5e-3, abs=2e-4)
    assert float(more.net.a.detach()) == pytest.approx(0.05 - 2e-2, abs=1e-3)
    assert few.residual_after == pytest.approx(exact_residual(0.045), rel=0.05)


def test_only_the_named_parameters_move():
    net = ExactPlusDrift(0.05, 0.02)
    r = refine(net, SHO, steps=3, optimizer="lbfgs", lr=1.0, parameters=["b"])
    assert float(r.net.a.detach()) == float(net.a.detach())  # frozen, bit for bit
    assert float(r.net.b.detach()) != pytest.approx(0.02, abs=1e-3)
    assert r.residual_after < r.residual_before
    # b alone cannot cancel a: the residual's minimum over b is positive
    t = np.linspace(0, 2, 200)
    rq, rp = 0.05 * (1 - t), 0.05 * (1 + 16 * t)  # b = 0; b adds (−t, +1)·b
    A = np.concatenate([-t, np.ones_like(t)])
    r0 = np.concatenate([rq, rp])
    b = -(A @ r0) / (A @ A)
    assert float(r.net.b.detach()) == pytest.approx(b, rel=1e-4)
    with pytest.raises(ValueError, match=r"name none of the network's parameters.*\['a', 'b'\]"):
        refine(net, SHO, steps=1, parameters=["branch"])


def test_the_starting_state_holds_exactly():
    net = ExactPlusDrift(0.3)
    t = np.array([0.0, 0.5, 1.0])
    r = refine(net, SHO, t, steps=2, q0=0.1, p0=-0.2, lr=1e-3)
    assert (r.q[0], r.p[0]) == (0.1, -0.2)  # y − y(0) + state, exactly at t = 0
    sensors = SHO.V(nh.SENSORS)
    r2 = refine(net, sensors, t, steps=0)  # sensor values: the 100-sensor spline
    assert (r2.q[0], r2.p[0]) == (0.0, 0.0)
    assert r2.residual_before == pytest.approx(exact_residual(0.3), rel=1e-3)


@pytest.mark.parametrize("kwargs, message", [
    ({"steps": -1}, "steps must be >= 0"),
    ({"steps": 1.5}, "steps must be >= 0"),
    ({"collocation": 1}, "collocation >= 2"),
    ({"optimizer": "sgd"}, "optimizer must be 'adam' or 'lbfgs', got 'sgd'"),
    ({"t": np.array([-0.1, 1.0])}, "t must be finite, non-negative"),
    ({"t": np.array([])}, "t must be finite"),
    ({"potential": np.ones(50)}, "got 50 sensor values"),
    ({"potential": np.full(100, np.nan)}, "must be finite"),
])
def test_errors_are_named(kwargs, message):
    args = {"potential": SHO, **kwargs}
    with pytest.raises(ValueError, match=message):
        refine(ExactPlusDrift(0.0), **args)


def test_a_query_coupled_network_is_refused():
    net = ExactPlusDrift(0.0)
    net.query_coupled = True
    with pytest.raises(ValueError, match="query_coupled False"):
        refine(net, SHO, steps=1)
