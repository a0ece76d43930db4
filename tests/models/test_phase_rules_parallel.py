"""PhaseONet's half-orbit inversion on numba's threads: bit for bit the serial rows."""

import numpy as np
import torch

import nh_operators as nh
from nh_operators.models.orbit_coordinates import invert_rows
from nh_operators.models.orbit_shape import edge_tables
from nh_operators.models import phase_rules
from nh_operators.models.phase_rules import RestQuadrature, rest_tables


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
    edges, rule_args = args[4:8], args[:4]
    for dtype in (np.float64, np.float32):
        serial = [np.empty((40, 128), dtype=dtype) for _ in range(2)]
        phase_rules._rest_rows_serial(*rule_args, *edges, *serial)
        parallel = [np.empty((40, 128), dtype=dtype) for _ in range(2)]
        phase_rules._rest_rows_parallel(*rule_args, *edges, *parallel)
        assert np.array_equal(serial[0], parallel[0])
        assert np.array_equal(serial[1], parallel[1])
        # the inversion's rows, abs(p) = P / T, cast once
        assert np.array_equal(serial[0], Q.astype(dtype))
        assert np.array_equal(serial[1], (P / T.numpy()[:, None]).astype(dtype))
    assert np.array_equal(rest_tables(*rule_args, edges, 128)[1], P / T.numpy()[:, None])
    assert Q.shape == (40, 128)
    # a half-orbit from q = 0 (h = 0) to the far turning point (h = 1/2), at rest there
    assert np.all(Q[:, 0] == 0) and np.all(np.diff(Q, axis=1) >= 0)
    np.testing.assert_allclose(P[:, -1], 0, atol=1e-6)
