"""The step grid of a single row (a level of one solve): the same numbers as the rows'."""

import numpy as np
import pytest

from nh_operators.solvers.rows import _grids, _one_grid


@pytest.mark.parametrize("seed", range(3))
def test_one_grid_equals_the_rows_grid_bit_for_bit(seed):
    rng = np.random.default_rng(seed)
    for _ in range(500):
        ts = np.sort(rng.uniform(0, rng.choice([1e-3, 2.0, 50.0]), rng.integers(1, 5)))
        if rng.random() < 0.1:
            ts[:] = 0.0
        sub = int(rng.choice([1, 2, 8, 64, 4096]))
        interval = float(rng.choice([2 / 99 / 8, rng.uniform(1e-4, 1)]))
        h, n = _one_grid(ts, sub, interval)
        hs, ns = _grids(ts[None], sub, np.array([interval]))
        assert (h, n) == (hs[0], ns[0]) and isinstance(n, int)


def test_one_grid_refuses_too_many_steps_with_the_rows_message():
    with pytest.raises(ValueError, match=r"t = 1e\+06 needs 3.17e\+09 fixed steps"):
        _one_grid(np.array([0.0, 1e6]), 64, 2 / 99 / 1)
