"""The asked order of a row solve's times: sorted for the solve, put back for the answer."""

import numpy as np
import pytest

from nh_operators.solvers._asked_order import in_asked_order, sorted_times


def test_shared_times_asked_sorted_need_no_order_and_are_not_copied() -> None:
    t = np.array([0.0, 0.5, 0.5, 1.25])  # non-decreasing, a repeat included
    order, ts = sorted_times(t, 1)
    assert order is None
    assert np.shares_memory(ts, t) and ts.shape == (1, 4)
    with pytest.raises(ValueError, match="read-only"):
        ts[0, 0] = 7.0  # the caller's times cannot be written through the view
    assert t[0] == 0.0
    order, ts = sorted_times(t, 3)
    assert order is None and ts.shape == (3, 4) and np.array_equal(ts[2], t)
    qa, pa = np.arange(4.0)[None], -np.arange(4.0)[None]
    q, p = in_asked_order(qa, pa, None, 1)
    assert q is qa and p is pa


@pytest.mark.parametrize("n", [1, 3])
def test_unsorted_shared_times_round_trip(n: int) -> None:
    t = np.array([1.5, 0.0, 0.75, 0.25, 0.75])
    order, ts = sorted_times(t, n)
    assert order is not None and ts.shape == (n, 5)
    assert np.array_equal(ts[-1], np.sort(t))
    # a state that is a function of the time comes back in the asked order
    q, p = in_asked_order(np.sin(ts), np.cos(ts), order, 1)
    assert np.array_equal(q, np.broadcast_to(np.sin(t), (n, 5)))
    assert np.array_equal(p, np.broadcast_to(np.cos(t), (n, 5)))


def test_per_row_times_round_trip_even_when_one_row_is_sorted() -> None:
    t = np.array([[0.0, 0.5, 1.0], [1.0, 0.0, 0.5]])
    order, ts = sorted_times(t, 2)
    assert order is not None
    assert np.array_equal(ts, [[0.0, 0.5, 1.0], [0.0, 0.5, 1.0]])
    q, p = in_asked_order(2 * ts, 3 * ts, order, 2)
    assert np.array_equal(q, 2 * t) and np.array_equal(p, 3 * t)
