"""Fixtures of the solving tests."""

import dataclasses

import numpy as np
import pytest
from calibration_helpers import use_calibration

import nh_operators as nh
from nh_operators.solving import loader


@pytest.fixture
def open_costs(monkeypatch):
    """A function that patches the shipped calibrations for the contract tests."""

    def patch(factor_scale=1.0):
        """The shipped calibrations with a network solve costing nothing, so that ``auto``
        tries a network wherever its domain admits the input (on this CPU a network is
        never expected to be cheaper, and the promise must hold wherever it is tried);
        ``factor_scale`` scales the factors (and the estimates they imply)."""
        for name in nh.available_pretrained():
            cal = loader.load(name).calibration
            use_calibration(monkeypatch, name, dataclasses.replace(
                cal, neural_seconds=0.0, neural_seconds_batched=0.0,
                factors={k: factor_scale * v for k, v in cal.factors.items()},
                estimate_quantiles=factor_scale * np.asarray(cal.estimate_quantiles),
                families={fam: dict(f, estimate_quantiles=[factor_scale * v for v in
                                                           f["estimate_quantiles"]])
                          if "estimate_quantiles" in f else f
                          for fam, f in cal.families.items()}))

    return patch
