"""single_threaded: one thread inside, counts restored, nested blocks free (issue 41)."""

import sys
import threading

import numba
import pytest

from nh_operators import _backend
from nh_operators._backend import single_threaded


@pytest.fixture
def two_numba_threads():
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba was started with one thread")
    before = numba.get_num_threads()
    numba.set_num_threads(2)
    yield
    numba.set_num_threads(before)


def test_numba_is_single_inside_nested_blocks_and_restored_after(two_numba_threads):
    with single_threaded():
        assert numba.get_num_threads() == 1
        with single_threaded():
            assert numba.get_num_threads() == 1
        assert numba.get_num_threads() == 1  # the inner block put nothing back
    assert numba.get_num_threads() == 2


def test_counts_are_restored_when_the_block_raises(two_numba_threads):
    with pytest.raises(RuntimeError, match="inside"):
        with single_threaded():
            raise RuntimeError("inside")
    assert numba.get_num_threads() == 2
    assert getattr(_backend._LOCAL, "depth", 0) == 0


def test_torch_imported_inside_an_outer_block_is_limited_by_an_inner_one(monkeypatch):
    counts = {"n": 3, "sets": []}

    class FakeTorch:  # stands for torch imported after the outer block began
        @staticmethod
        def get_num_threads():
            return counts["n"]

        @staticmethod
        def set_num_threads(n):
            counts["sets"].append(n)
            counts["n"] = n

    monkeypatch.delitem(sys.modules, "torch", raising=False)
    with single_threaded():
        monkeypatch.setitem(sys.modules, "torch", FakeTorch)
        with single_threaded():
            assert counts["n"] == 1
            with single_threaded():  # already limited: not set again
                assert counts["sets"] == [1]
        assert counts["n"] == 3  # put back by the block that limited it
    assert counts["sets"] == [1, 3]


def test_numba_count_of_another_thread_is_left_alone(two_numba_threads):
    seen = []
    inside, done = threading.Event(), threading.Event()

    def other():
        inside.wait()
        seen.append(numba.get_num_threads())
        done.set()

    worker = threading.Thread(target=other)
    worker.start()
    with single_threaded():
        inside.set()
        done.wait(10)
    worker.join()
    assert seen == [2]
