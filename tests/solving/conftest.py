"""Fixtures of the solving tests."""

import pytest

import nh_operators as nh
from nh_operators.solving import auto_solve


@pytest.fixture
def open_costs(monkeypatch):
    """A function that patches the shipped calibrations for the contract tests."""

    def patch(factor_scale=1.0):
        """The shipped calibrations with a network solve costing nothing, so that ``auto``
        tries a network wherever its domain admits the input (on this CPU a network is
        never expected to be cheaper, and the promise must hold wherever it is tried);
        ``factor_scale`` scales the factor (and the estimates it implies)."""
        for name in nh.available_pretrained():
            model = auto_solve._model(name)
            cal = dict(model.calibration)
            cal["neural_seconds"] = cal["neural_seconds_batched"] = 0.0
            cal["factor"] *= factor_scale
            for key in ("factors", "factors_sensors", "factors_early", "factors_sensors_early",
                        "factors_fine", "factors_sensors_fine"):
                if key in cal:
                    cal[key] = [factor_scale * f for f in cal[key]]
            cal["estimate_quantiles"] = [factor_scale * v for v in cal["estimate_quantiles"]]
            cal["families"] = {fam: dict(f, estimate_quantiles=[factor_scale * v for v in
                                                                 f["estimate_quantiles"]])
                               if "estimate_quantiles" in f else f
                               for fam, f in cal["families"].items()}
            monkeypatch.setattr(model, "calibration", cal)
        auto_solve._ranked.cache_clear()

    return patch
