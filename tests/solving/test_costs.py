"""The costs ``auto`` weighs: the classical one depends on the latest asked time."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.solving import SHORT_HORIZON, auto_solve, horizon_share
from nh_operators.solving.costs import _classical_seconds, _horizon_key

TOLS = [1e-1, 1e-12]


def calibration(full, short=None, batched=None):
    cal = {"classical_tols": TOLS, "classical_seconds": [full] * 2}
    if short is not None:
        cal["classical_seconds_short"] = [short] * 2
    if batched is not None:
        cal["classical_seconds_batched"] = [batched] * 2
    return cal


def test_the_classical_cost_is_linear_in_the_horizon_through_the_two_timings():
    assert SHORT_HORIZON == 0.5
    proportional = calibration(1.0, short=0.25, batched=0.01)   # no fixed part
    for horizon, share in ((2.0, 1.0), (1.0, 0.5), (0.5, 0.25), (0.1, 0.05), (5.0, 1.0)):
        assert _classical_seconds(proportional, 1e-3, horizon=horizon) == pytest.approx(share)
        assert _classical_seconds(proportional, 1e-3, batched=True,
                                  horizon=horizon) == pytest.approx(0.01 * share)
    fixed = calibration(1.0, short=1.0)            # all overhead: the horizon does not matter
    assert _classical_seconds(fixed, 1e-3, horizon=0.1) == pytest.approx(1.0)
    half = calibration(1.0, short=0.625)           # c0 = 1/2: 0.5 + 0.5 · h / 2
    assert _classical_seconds(half, 1e-3, horizon=1.0) == pytest.approx(0.75)
    assert horizon_share(0.625, 0.0) == pytest.approx(0.5)
    # noise outside the model is clamped: a short timing above the full one is all fixed,
    # one below the proportional share has no fixed part
    assert horizon_share(1.3, 0.2) == 1.0 and horizon_share(0.1, 1.0) == pytest.approx(0.5)
    # a calibration measured before the short timing existed weighs the whole grid
    assert _classical_seconds(calibration(1.0), 1e-3, horizon=0.1) == 1.0


def test_the_horizon_key_rounds_the_latest_time_up():
    assert _horizon_key(np.array([0.1, 0.731])) == 0.8
    assert _horizon_key(np.array([[0.2], [2.0]])) == 2.0
    assert _horizon_key(np.array([0.3])) == 0.3


def test_a_network_dearer_than_a_short_classical_solve_is_not_offered_there(monkeypatch):
    model = auto_solve._model("deeponet-alg1")
    # its estimate meets tol 1 on every calibration row
    cal = dict(calibration(1.0, short=0.25), factor=1.0, probabilities=[0.0, 0.5, 1.0],
               estimate_quantiles=[1e-9, 1e-8, 1e-7], neural_seconds=0.6)
    monkeypatch.setattr(model, "calibration", cal)
    auto_solve._ranked.cache_clear()
    ids = tuple(id(auto_solve._calibration(n)) for n in auto_solve._networks())

    def offered(horizon):
        return "deeponet-alg1" in [c[0] for c in auto_solve._ranked(1.0, "formula", ids,
                                                                    False, False, horizon)[0]]

    # 0.6 s against the classical 1.0 s on the whole grid, 0.75 s up to t = 1.5, 0.5 s
    # up to t = 1
    assert offered(2.0) and offered(1.5) and not offered(1.0) and not offered(0.5)
    auto_solve._ranked.cache_clear()
    short = nh.solve("sho", [0.2, 0.9], tol=1.0)
    assert "deeponet-alg1" not in [a["method"] for a in short.tried]
