"""Preloading shipped networks: every name loads once, and a first solve then pays
nothing for weights."""

import pytest

import nh_operators as nh
from nh_operators.solving import loader


def test_preload_loads_each_named_network_once_and_names_an_unknown_one(monkeypatch):
    monkeypatch.setattr(loader, "_LOADED", {})
    monkeypatch.setattr(loader, "_NETWORKS", {})
    assert nh.preload(["phaseonet-paper", "traonet"], warm=False) == [
        "phaseonet-paper", "traonet-alg1"]
    loaded = dict(loader._NETWORKS)
    assert set(loaded) == {"phaseonet-paper", "traonet-alg1"}
    nh.preload(["phaseonet-paper"])                   # warm: a forward, no new load
    assert loader._NETWORKS["phaseonet-paper"] is loaded["phaseonet-paper"]
    with pytest.raises(ValueError, match="no pretrained model 'nope'; available"):
        nh.preload(["nope"])


def test_a_solve_after_preload_does_not_load_again(monkeypatch):
    from nh_operators.solving import shipped

    monkeypatch.setattr(loader, "_LOADED", {})
    monkeypatch.setattr(loader, "_NETWORKS", {})
    nh.preload(["phaseonet-paper-states"])

    def no_more(name, **kwargs):
        raise AssertionError(f"{name} loaded again")

    monkeypatch.setattr(shipped, "pretrained", no_more)
    sol = nh.solve("sho", [0.5, 1.0], method="phaseonet-paper-states", q0=0.3, p0=0.2)
    assert sol.kind == "neural" and sol.method == "phaseonet-paper-states"


def test_weights_exported_later_in_the_process_are_seen(tmp_path, monkeypatch):
    """The list of shipped networks is read again after an export (issue 40)."""
    import shutil

    from nh_operators.solving import catalog, export_pretrained, shipped

    weights = tmp_path / "weights"
    shutil.copytree(catalog.WEIGHTS / "deeponet-paper", weights / "deeponet-paper")
    monkeypatch.setattr(catalog, "WEIGHTS", weights)
    monkeypatch.setattr(loader, "WEIGHTS", weights)
    monkeypatch.setattr(shipped, "WEIGHTS", weights)
    catalog.refresh()
    monkeypatch.setattr(loader, "_LOADED", {})
    monkeypatch.setattr(loader, "_NETWORKS", {})
    try:
        assert nh.available_pretrained() == ["deeponet-paper"]
        export_pretrained(weights / "deeponet-paper", weights / "copy")
        assert nh.available_pretrained() == ["copy", "deeponet-paper"]
        assert loader.load("copy").calibration is None  # exported, not yet calibrated
        sol = nh.solve("sho", [0.5, 1.0], method="copy")
        assert sol.kind == "neural" and sol.method == "copy"
    finally:
        monkeypatch.undo()
        catalog.refresh()
