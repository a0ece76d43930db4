import time

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.evaluation import (
    Method,
    device_info,
    seconds_per_trajectory,
    time_call,
)


class Sleeper(Method):
    """Costs a fixed 2 ms per call plus 0.2 ms per potential; records batch sizes."""

    name = family = "sleeper"
    kind = "classical"

    def __init__(self):
        self.sizes = []
        self.syncs = 0

    def __call__(self, V, t):
        self.sizes.append(len(V))
        time.sleep(0.002 + 0.0002 * len(V))
        return np.zeros((len(V), len(t))), np.zeros((len(V), len(t)))

    def synchronize(self):
        self.syncs += 1


def test_time_call_counts_warmup_repeats_and_synchronisation():
    calls, syncs = [], []
    times = time_call(lambda: calls.append(1) or time.sleep(0.003), repeats=4, warmup=2,
                      synchronize=lambda: syncs.append(1))
    assert len(times) == 4 and len(calls) == 6 and len(syncs) == 5
    assert min(times) >= 0.003
    with pytest.raises(ValueError, match="repeats ≥ 1"):
        time_call(lambda: None, repeats=0)


def test_seconds_per_trajectory_batch_1_and_batched():
    m = Sleeper()
    V = np.zeros((50, 100))
    r = seconds_per_trajectory(m, V, nh.TIMES, n_single=3, repeats=2)
    # 3 potentials × (1 warm-up + 2 timed) at batch 1, then 1 + 2 calls on all 50
    assert m.sizes == [1] * 9 + [50] * 3
    assert m.syncs == 3 * 3 + 3
    assert r["batch_1"] >= 0.0022 and r["batch_1_stats"]["n"] == 3
    assert r["batched"] >= (0.002 + 0.0002 * 50) / 50
    assert r["batched"] < r["batch_1"] and r["batched_size"] == 50 and r["repeats"] == 2
    with pytest.raises(ValueError, match="shape"):
        seconds_per_trajectory(m, np.zeros(100), nh.TIMES)


def test_device_info_names_the_cpu_and_threads():
    import torch

    info = device_info("cpu")
    assert info["device"].startswith("cpu: ") and "logical cores" in info["device"]
    assert info["torch_threads"] == torch.get_num_threads() and info["numba_threads"] >= 1


def test_busy_machine_warning_uses_the_load_average():
    from nh_operators.evaluation import busy_machine_warning

    assert busy_machine_warning({"load_average": 0.5, "cpu_count": 2}) is None
    text = busy_machine_warning({"load_average": 3.1, "cpu_count": 2})
    assert "load average 3.1 on 2 cores" in text
    assert busy_machine_warning({"load_average": None, "cpu_count": 2}) is None
    assert "load_average" in device_info()
