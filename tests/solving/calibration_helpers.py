"""Calibrations for the solving tests: a fake one, and one put in place for a test."""

import dataclasses

from nh_operators.solving import loader
from nh_operators.solving.calibration import Calibration


def use_calibration(monkeypatch, name, calibration):
    """Shipped network ``name`` with ``calibration`` for this test (its network stays
    loaded; the rankings are keyed on the calibrations, so they follow)."""
    shipped = dataclasses.replace(loader.load(name), calibration=calibration)
    monkeypatch.setitem(loader._LOADED, name, shipped)
    return shipped


def fake_calibration(factor=1.0, neural_seconds=1e-5, estimates=(1e-9, 1e-8, 1e-7),
                     classical=(1.0, 1.0), short=None, tols=(1e-1, 1e-12), kinds=None):
    """A format-2 calibration: one ``factor`` for every kind and call, the in-distribution
    estimate quantiles ``estimates`` at probabilities (0, 0.5, 1) (the sensor family the
    same), the network's seconds and the classical ones (every kind alike, but for the
    full-grid seconds of ``kinds``: kind -> seconds)."""
    table = {"full": list(classical),
             "short": list(classical) if short is None else list(short)}
    tables = {k: dict(table, **({"full": list((kinds or {})[k]), "short": list(kinds[k])}
                                if k in (kinds or {}) else {}))
              for k in ("bspline", "sensors", "formula")}
    return Calibration.from_json({
        "format": 2, "limits": [1e-3, 1e-2],
        "factors": {truth: {call: [factor] * 3 for call in ("plain", "early")}
                    for truth in ("exact", "sensors")},
        "probabilities": [0.0, 0.5, 1.0], "estimate_quantiles": list(estimates),
        "families": {"sensors": {"estimate_quantiles": list(estimates)}},
        "costs": {"neural_seconds": neural_seconds, "neural_seconds_batched": neural_seconds,
                  "classical_tols": list(tols),
                  "classical_seconds": tables,
                  "device": None},
        "info": {}})
