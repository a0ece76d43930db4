"""The costs ``auto`` weighs: the classical one depends on the latest asked time."""

import numpy as np
import pytest
from calibration_helpers import fake_calibration, use_calibration

import nh_operators as nh
from nh_operators.solving import ranking
from nh_operators.solving.costs import SHORT_HORIZON, horizon_key, horizon_share
from nh_operators.solving.kinds import InputKind

TOLS = [1e-1, 1e-12]
BSPLINE = InputKind.BSPLINE


def calibration(full, short=None, batched=None):
    cal = fake_calibration(classical=[full] * 2, short=None if short is None else [short] * 2)
    if batched is not None:
        cal.classical[BSPLINE]["batched"] = np.array([batched] * 2)
    return cal


def test_the_classical_cost_is_linear_in_the_horizon_through_the_two_timings():
    assert SHORT_HORIZON == 0.5
    proportional = calibration(1.0, short=0.25, batched=0.01)   # no fixed part
    for horizon, share in ((2.0, 1.0), (1.0, 0.5), (0.5, 0.25), (0.1, 0.05), (5.0, 1.0)):
        assert proportional.classical_seconds(1e-3, BSPLINE, horizon=horizon) == \
            pytest.approx(share)
        assert proportional.classical_seconds(1e-3, BSPLINE, batched=True,
                                              horizon=horizon) == pytest.approx(0.01 * share)
    fixed = calibration(1.0, short=1.0)            # all overhead: the horizon does not matter
    assert fixed.classical_seconds(1e-3, BSPLINE, horizon=0.1) == pytest.approx(1.0)
    half = calibration(1.0, short=0.625)           # c0 = 1/2: 0.5 + 0.5 · h / 2
    assert half.classical_seconds(1e-3, BSPLINE, horizon=1.0) == pytest.approx(0.75)
    assert horizon_share(0.625, 0.0) == pytest.approx(0.5)
    # noise outside the model is clamped: a short timing above the full one is all fixed,
    # one below the proportional share has no fixed part
    assert horizon_share(1.3, 0.2) == 1.0 and horizon_share(0.1, 1.0) == pytest.approx(0.5)
    # formulas are solved one by one in solve_many: their per-row cost is one call's
    assert half.classical_seconds(1e-3, InputKind.FORMULA, batched=True) == 1.0


def test_the_horizon_key_rounds_the_latest_time_up():
    assert horizon_key(np.array([0.1, 0.731])) == 0.8
    assert horizon_key(np.array([[0.2], [2.0]])) == 2.0
    assert horizon_key(np.array([0.3])) == 0.3


def test_a_network_dearer_than_a_short_classical_solve_is_not_offered_there(monkeypatch):
    # its estimate meets tol 1 on every calibration row
    cal = fake_calibration(1.0, 0.6, [1e-9, 1e-8, 1e-7], classical=[1.0, 1.0],
                           short=[0.25, 0.25])
    use_calibration(monkeypatch, "deeponet-alg1", cal)

    def offered(horizon):
        return "deeponet-alg1" in [c[0] for c in ranking.ranked(1.0, InputKind.FORMULA,
                                                                False, False, horizon)[0]]

    # 0.6 s against the classical 1.0 s on the whole grid, 0.75 s up to t = 1.5, 0.5 s
    # up to t = 1
    assert offered(2.0) and offered(1.5) and not offered(1.0) and not offered(0.5)
    short = nh.solve("sho", [0.2, 0.9], tol=1.0)
    assert "deeponet-alg1" not in [a["method"] for a in short.tried]
