"""Preloading shipped networks: every name loads once, and a first solve then pays
nothing for weights."""

import pytest

import nh_operators as nh
from nh_operators.solving import auto_solve


def test_preload_loads_each_named_network_once_and_names_an_unknown_one(monkeypatch):
    monkeypatch.setattr(auto_solve, "_LOADED", {})
    assert nh.preload(["phaseonet-paper", "traonet"], warm=False) == [
        "phaseonet-paper", "traonet-alg1"]
    loaded = dict(auto_solve._LOADED)
    assert set(loaded) == {"phaseonet-paper", "traonet-alg1"}
    nh.preload(["phaseonet-paper"])                   # warm: a forward, no new load
    assert auto_solve._LOADED["phaseonet-paper"] is loaded["phaseonet-paper"]
    with pytest.raises(ValueError, match="no pretrained model 'nope'; available"):
        nh.preload(["nope"])


def test_a_solve_after_preload_does_not_load_again(monkeypatch):
    from nh_operators.solving import shipped

    monkeypatch.setattr(auto_solve, "_LOADED", {})
    nh.preload(["phaseonet-paper-states"])

    def no_more(name, **kwargs):
        raise AssertionError(f"{name} loaded again")

    monkeypatch.setattr(shipped, "pretrained", no_more)
    sol = nh.solve("sho", [0.5, 1.0], method="phaseonet-paper-states", q0=0.3, p0=0.2)
    assert sol.kind == "neural" and sol.method == "phaseonet-paper-states"
