import math

import pytest

from nh_operators.evaluation import (
    faster_interval,
    faster_statements,
    work_precision_markdown,
    work_precision_rows,
)


def row(name, seconds, loss, kind="classical"):
    return {"name": name, "seconds": seconds, "mean_L_tot": loss, "kind": kind}


CLASSICAL = [row("rk4_1", 1e-5, 3e-4), row("rk4_4", 2e-5, 4e-6), row("dop", 1e-2, 1e-9)]


def test_interval_between_the_networks_loss_and_the_best_as_fast_solver():
    net = row("net", 5e-3, 1e-7, "neural")  # only rk4_1/rk4_4 are as fast; best is 4e-6
    assert faster_interval(net, CLASSICAL)[:2] == (1e-7, 4e-6)
    assert faster_interval(net, CLASSICAL)[2]["name"] == "rk4_4"


def test_interval_is_empty_when_a_solver_is_as_fast_and_as_accurate():
    low, high, blocker = faster_interval(row("net", 3e-5, 1e-2, "neural"), CLASSICAL)
    assert low is None and high is None and blocker["name"] == "rk4_4"


def test_interval_is_unbounded_when_no_solver_is_as_fast():
    low, high, blocker = faster_interval(row("net", 1e-6, 0.1, "neural"), CLASSICAL)
    assert low == 0.1 and math.isinf(high) and blocker is None


def test_statements_name_the_numbers():
    rows = CLASSICAL + [row("a", 5e-3, 1e-7, "neural"), row("b", 3e-5, 1e-2, "neural")]
    a, b = faster_statements(rows)
    assert a.startswith("a (large batch, 5.0 ms") and "[1.00e-07, 4.00e-06)" in a
    assert "for targets of 4.00e-06 or looser, rk4_4 (20.0 µs)" in a
    assert "at no accuracy: rk4_4 takes 20.0 µs and reaches 4.00e-06" in b
    assert "No network" in faster_statements(CLASSICAL)[0]


def results():
    def m(kind, loss, b1, bt, n=100):
        return {"kind": kind, "family": "f", "device": "cpu: x", "test": {"mean": loss, "n": n},
                "seconds_per_trajectory": {"batch_1": b1, "batched": bt}}
    return {"methods": {"slow": m("classical", 1e-9, 1e-2, 1e-2, 5),
                        "fast": m("classical", 1e-4, 1e-4, 1e-5),
                        "net": m("neural", 1e-6, 1e-3, 1e-6),
                        "untimed": m("neural", 1e-3, None, None)}}


def test_rows_sorted_by_time_skip_untimed_and_check_the_regime():
    rows = work_precision_rows(results(), "batched")
    assert [r["name"] for r in rows] == ["net", "fast", "slow"]
    assert [r["name"] for r in work_precision_rows(results(), "batch_1")] == ["fast", "net",
                                                                              "slow"]
    with pytest.raises(ValueError, match="regime"):
        work_precision_rows(results(), "gpu")


def test_markdown_table_and_both_regimes():
    text = work_precision_markdown(results())
    assert "| net | neural | 100 | 1.000e-06 | 1.000e-03 | 1.000e-06 | cpu: x |" in text
    assert "| untimed | neural | 100 | 1.000e-03 | – | – |" in text
    assert "**Large batch.**" in text and "**Batch 1.**" in text
    assert "every accuracy target ≥ 1.00e-06" in text  # batched: net is the fastest
