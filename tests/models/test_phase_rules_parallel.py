"""PhaseONet's half-orbit inversion on numba's threads: bit for bit the serial rows."""

import numpy as np
import torch

import nh_operators as nh
from nh_operators.models.orbit_coordinates import invert_rows
from nh_operators.models.orbit_shape import edge_tables
from nh_operators.models.phase_rules import RestQuadrature, invert_rows_parallel


def test_parallel_inversion_equals_the_serial_rows_exactly():
    space = nh.BoundedPotentialSpace(seed=5)
    V = torch.tensor(np.asarray(space.eval_batch(space.random(40), nh.SENSORS[:, None],
                                                 dtype=np.float64)))
    rule = RestQuadrature()
    s, w = rule.nodes, rule.weights
    f = rule.jacobian * torch.rsqrt_(rule._squared_speed(V))
    T = 2 * (f @ w)
    args = (f.numpy(), s.numpy(), w.numpy(), T.numpy(), *edge_tables(s.numpy(), w.numpy()),
            128)
    Q, P = invert_rows(*args)
    Qp, Pp = invert_rows_parallel(*args)
    assert Q.shape == (40, 128) and np.array_equal(Q, Qp) and np.array_equal(P, Pp)
    # a half-orbit from q = 0 (h = 0) to the far turning point (h = 1/2), at rest there
    assert np.all(Q[:, 0] == 0) and np.all(np.diff(Q, axis=1) >= 0)
    np.testing.assert_allclose(P[:, -1], 0, atol=1e-6)
