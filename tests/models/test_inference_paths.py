"""predict's shortcuts for the training grid: the same answer as the general path."""

import warnings

import numpy as np
import pytest
import torch

import nh_operators as nh


@pytest.fixture(scope="module")
def model():
    return nh.pretrained("phaseonet-alg1")


@pytest.fixture(scope="module")
def V():
    space = nh.BoundedPotentialSpace(seed=13)
    return space.potentials(space.random(5)).V(nh.SENSORS)


def test_the_grid_itself_and_its_copy_give_the_same_bits(model, V):
    with warnings.catch_warnings():
        warnings.simplefilter("error")                      # read-only TIMES: no warning
        q, p = nh.predict(model, V, nh.TIMES)
    for t in (nh.TIMES.copy(), list(nh.TIMES), nh.TIMES[:, None]):
        q2, p2 = nh.predict(model, V, t)
        assert q2.tobytes() == q.tobytes() and p2.tobytes() == p.tobytes()
    q1, _ = nh.predict(model, V[2], nh.TIMES)               # one potential: (M,) each
    row, _ = nh.predict(model, V[2:3], nh.TIMES)
    assert q1.shape == (100,) and q1.tobytes() == row[0].tobytes()


def test_non_finite_inputs_still_raise_on_the_grid(model, V):
    W = V.copy()
    W[1, 7] = np.inf
    with pytest.raises(ValueError, match="^V and t must be finite$"):
        nh.predict(model, W, nh.TIMES)
    with pytest.raises(ValueError, match="^V and t must be finite$"):
        nh.predict(model, V, np.r_[nh.TIMES[:-1], np.nan])


class Scribbler(torch.nn.Module):
    """A float64 network that writes on its input (a bad habit predict must survive)."""

    def __init__(self):
        super().__init__()
        self.scale = torch.nn.Parameter(torch.ones((), dtype=torch.float64))

    def forward(self, inputs):
        v, t = inputs
        v.mul_(2.0)
        q = v[:, :1] * t[None, :, 0] * self.scale
        return torch.stack([q, -q], dim=-1)


def test_predict_reads_the_callers_array_without_a_copy_but_never_lends_it(V):
    W = V.copy()
    q, p = nh.predict(Scribbler(), W, [0.5, 1.0])
    assert W.tobytes() == V.tobytes()                       # the network wrote on its own copy
    np.testing.assert_array_equal(q, 2 * V[:, :1] * [0.5, 1.0])
    np.testing.assert_array_equal(p, -q)
    ro = V.copy()
    ro.flags.writeable = False                              # read-only: copied, no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        q2, _ = nh.predict(Scribbler(), ro, [0.5, 1.0])
    np.testing.assert_array_equal(q2, q)
