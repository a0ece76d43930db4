import numpy as np
import pytest
import torch
from model_helpers import tiny

import nh_operators as nh
from nh_operators._backend import single_threaded
from nh_operators.evaluation import (
    CLASSICAL_METHODS,
    EVALUATE_BASELINES,
    ClassicalMethod,
    Method,
    NeuralMethod,
    classical_methods,
    dop853_sensors,
)

SHO = nh.PHYSICAL_POTENTIALS["sho"]


def sho_sensors(n=1):
    return np.tile(SHO.V(nh.SENSORS), (n, 1))


def test_registry_names_families_and_kinds():
    assert set(EVALUATE_BASELINES) <= set(CLASSICAL_METHODS)
    for name, m in CLASSICAL_METHODS.items():
        assert m.name == name and m.kind == "classical" and name.startswith(m.family)
        assert m.description
    assert [m.batched for m in CLASSICAL_METHODS.values()].count(False) == 4  # DOP853
    assert {"rk4_sensors_1", "rk4_sensors_16", "verlet_sensors_16", "yoshida8_sensors_4",
            "paper_rk4", "dop853_sensors_1e-12"} <= set(CLASSICAL_METHODS)


@pytest.mark.parametrize("name,bound", [("rk4_sensors_4", 1e-15), ("yoshida8_sensors_2", 1e-12),
                                        ("verlet_sensors_16", 1e-5), ("paper_rk4", 1e-6),
                                        ("dop853_sensors_1e-10", 1e-15)])
def test_classical_methods_on_the_sho_against_the_exact_solution(name, bound):
    q, p = CLASSICAL_METHODS[name](sho_sensors(2), nh.TIMES)
    qe, pe = SHO.exact(nh.TIMES)
    assert q.shape == p.shape == (2, 100) and q.dtype == np.float64
    loss = 0.5 * (np.mean((q - qe) ** 2, axis=1) + np.mean((p - pe) ** 2, axis=1))
    assert np.all(loss < bound)
    np.testing.assert_array_equal(q[0], q[1])


def test_dop853_keeps_the_order_of_unsorted_times_and_converges():
    t = np.array([1.5, 0.25, 0.0, 1.0])
    q, p = dop853_sensors(sho_sensors(), t, 1e-11)
    qe, pe = SHO.exact(t)
    assert np.max(np.abs(q[0] - qe)) < 1e-8 and np.max(np.abs(p[0] - pe)) < 1e-8
    q6, _ = dop853_sensors(sho_sensors(), t, 1e-5)
    assert np.max(np.abs(q6[0] - qe)) > np.max(np.abs(q[0] - qe))


def test_classical_methods_selection_and_unknown_names():
    assert list(classical_methods(["paper_rk4", "rk4_sensors_1"])) == ["paper_rk4",
                                                                        "rk4_sensors_1"]
    assert classical_methods([]) == {}
    with pytest.raises(ValueError, match="unknown classical method.*'rk5'.*choose from"):
        classical_methods(["rk5"])


def test_method_is_abstract_and_classical_method_passes_float64():
    with pytest.raises(TypeError):
        Method()
    seen = {}

    def run(V, t):
        seen["dtypes"] = V.dtype, t.dtype
        return V[:, :1] * t, V[:, :1] * t

    m = ClassicalMethod("x", run, "x")
    m(np.zeros((2, 100), dtype=np.float32), [0.0, 1.0])
    assert seen["dtypes"] == (np.float64, np.float64)


def test_neural_method_equals_predict_and_reports_its_device():
    net = tiny("deeponet")
    m = NeuralMethod(net, "tiny", batch_size=3)
    V = sho_sensors(5)
    q, p = m(V, nh.TIMES[:7])
    qr, pr = nh.predict(net, V, nh.TIMES[:7])
    # float32 results may differ in the last bits between batch sizes (BLAS blocking)
    np.testing.assert_allclose(q, qr, rtol=0, atol=1e-5)
    np.testing.assert_allclose(p, pr, rtol=0, atol=1e-5)
    assert (m.kind, m.device, m.family) == ("neural", "cpu", "tiny")
    assert NeuralMethod(net).name == type(net).__name__.lower()


def test_neural_method_from_run(tmp_path):
    from nh_operators.data import generate_dataset

    data = generate_dataset(20, 4, tmp_path / "d.h5", progress=False)
    cfg = nh.TrainConfig("deeponet", preset="cpu", arch={"hidden_size": 8, "branches": 2,
                                                          "hidden_layers": 1},
                         epochs=1, seed=0, batch_size=8)
    net, _ = nh.train(cfg, tmp_path / "d.h5", tmp_path / "run", progress=False)
    m = NeuralMethod.from_run(tmp_path / "run")
    assert m.name == "deeponet" and m.config["epochs"] == 1
    assert m.run_dir == str(tmp_path / "run")
    q, _ = m(data.V[:4], data.t)
    with torch.no_grad():
        direct = net((torch.as_tensor(data.V[:4], dtype=torch.float32),
                      torch.as_tensor(data.t[:, None], dtype=torch.float32)))
    np.testing.assert_allclose(q, direct[..., 0].double().numpy(), rtol=0, atol=1e-6)
    with pytest.raises(FileNotFoundError):
        NeuralMethod.from_run(tmp_path / "missing")


@pytest.mark.parametrize("name,coupled,arch", [
    ("traonet", True, {}), ("mambonet", True, {}), ("varonet", False, {}),
    ("varonet", True, {"grid_decoder": False}), ("deeponet", False, {}), ("fno", False, {})])
def test_query_coupling_is_declared_truthfully_and_predict_is_pointwise(name, coupled, arch):
    import warnings

    net = tiny(name, **arch)
    assert getattr(net, "query_coupled", False) is coupled
    V = sho_sensors(3) - np.linspace(0, 0.5, 3)[:, None] * np.sin(np.pi * nh.SENSORS)
    idx = [10, 50, 90]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # predict never warns: coupled nets run on the grid
        q_full, _ = nh.predict(net, V, nh.TIMES)
        q_sub, _ = nh.predict(net, V, nh.TIMES[idx])
    assert np.abs(q_sub - q_full[:, idx]).max() < 1e-5
    # the declaration is truthful: the network itself answers otherwise in other company
    net.eval()  # VaRONet samples its latent in training mode
    with torch.no_grad():
        raw = net((torch.as_tensor(V, dtype=torch.float32),
                   torch.as_tensor(nh.TIMES[idx, None], dtype=torch.float32)))
    gap = np.abs(raw[..., 0].double().numpy() - q_full[:, idx]).max()
    assert (gap > 1e-4) if coupled else (gap < 1e-5)


def test_neural_method_fast_paths_keep_every_answer_warning_and_error():
    """The grid nh.TIMES, a float64 array and resting starts take shortcuts (no copies, no
    re-checks); a copy of the grid, a list and NumPy starts take the general path."""
    m = nh.pretrained("deeponet-alg1")
    space = nh.BoundedPotentialSpace(seed=12)
    V = space.potentials(space.random(6)).V(nh.SENSORS)
    q, p = m(V, nh.TIMES)
    for args in [(V, nh.TIMES.copy()), (V.tolist(), list(nh.TIMES)),
                 (V, nh.TIMES[:, None], np.zeros(6), np.float64(0.0))]:
        q2, p2 = m(*args)
        assert q2.tobytes() == q.tobytes() and p2.tobytes() == p.tobytes()
    # the call ran on one thread (6 rows); so does predict here: torch's reductions on two
    # threads round differently on some CPUs (seen on a 2-core AMD EPYC)
    with single_threaded():
        qp, pp = nh.predict(m, V, nh.TIMES)
    assert qp.tobytes() == q.tobytes() and pp.tobytes() == p.tobytes()
    before = V.copy()
    m(V, nh.TIMES)
    assert V.tobytes() == before.tobytes()                   # the input is only read
    W = V.copy()
    W[4] = 2 - 88 * nh.SENSORS * (1 - nh.SENSORS)            # dips to -20: out of range
    with pytest.warns(nh.OutOfDomainWarning, match=r"V\[4\] \(1 of 6 rows\) has values "
                      r"below -2\.08286 .*: min V = -20 in row 4") as record:
        m(W, nh.TIMES)
    assert record[0].filename == __file__                    # reported at the caller
    with pytest.raises(ValueError, match="deeponet-alg1: times must be finite and ≥ 0, "
                                         "got nan"):
        m(V, [0.5, np.nan])
    with pytest.raises(ValueError, match="is not asked beyond it \\(got t = 2.5\\)"):
        m(V, [0.5, 2.5])
    with pytest.raises(ValueError, match="trained from the state \\(0, 0\\) only"):
        m(V, nh.TIMES, q0=np.array([0, 0, 0, 0, 0, 0.1]))
    with pytest.raises(ValueError, match="trained from the state \\(0, 0\\) only"):
        m(V, nh.TIMES, p0=-1)


def test_a_few_rows_run_on_one_thread_and_the_counts_come_back():
    import numba
    import torch

    from nh_operators.evaluation.methods import THREADS_FROM

    net = tiny("deeponet")
    seen = []
    hook = net.register_forward_hook(
        lambda *_: seen.append((torch.get_num_threads(), numba.get_num_threads())))
    before = torch.get_num_threads(), numba.get_num_threads()
    torch.set_num_threads(2)
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    try:
        wide = torch.get_num_threads(), numba.get_num_threads()
        m = NeuralMethod(net, "tiny")
        m(sho_sensors(1)[0], nh.TIMES[:5])             # one potential
        m(sho_sensors(THREADS_FROM - 1), nh.TIMES[:5])
        m(sho_sensors(THREADS_FROM), nh.TIMES[:5])     # a batch keeps the caller's counts
        assert seen == [(1, 1), (1, 1), wide]
        assert (torch.get_num_threads(), numba.get_num_threads()) == wide
    finally:
        hook.remove()
        torch.set_num_threads(before[0])
        numba.set_num_threads(before[1])
