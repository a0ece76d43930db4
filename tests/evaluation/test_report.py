import json

import numpy as np
import pytest
from model_helpers import tiny

import nh_operators as nh
from nh_operators.cli import main
from nh_operators.data import generate_dataset
from nh_operators.evaluation import (
    ClassicalMethod,
    EvaluationSettings,
    NeuralMethod,
    classical_methods,
    evaluate_methods,
    loss_per_sample,
    physical_reference,
    write_report,
)

FAST = EvaluationSettings(n_unbatched=4, n_single=2, n_batched=8, repeats=1)
REQUIRED = {"test", "physical", "seconds_per_trajectory", "device"}


@pytest.fixture(scope="module")
def testset():
    return generate_dataset(24, 11, progress=False)


@pytest.fixture(scope="module")
def evaluated(testset):
    methods = classical_methods(["rk4_sensors_4", "paper_rk4", "dop853_sensors_1e-08"])
    methods["net"] = NeuralMethod(tiny("deeponet"), "net", domain_check=False)
    return methods, evaluate_methods(methods, testset, FAST, progress=False)


def test_losses_equal_an_independent_computation(testset, evaluated):
    _, (results, arrays) = evaluated
    q, p = nh.integrate_sensors(testset.V, testset.t, "rk4", 4)
    loss = loss_per_sample(q, p, testset.q, testset.p)["L_tot"]
    rk4 = results["methods"]["rk4_sensors_4"]
    assert rk4["test"]["mean"] == pytest.approx(loss.mean(), rel=1e-12)
    assert rk4["test"]["median"] == pytest.approx(np.median(loss), rel=1e-12)
    np.testing.assert_allclose(arrays["rk4_sensors_4"]["L_tot"], loss, rtol=1e-12)
    assert int(arrays["rk4_sensors_4"]["worst"]) == int(np.argmax(loss))
    qs, ps = nh.integrate_sensors(nh.PHYSICAL_POTENTIALS["sho"].V(nh.SENSORS), testset.t, "rk4", 4)
    sho = loss_per_sample(qs, ps, *physical_reference("sho", testset.t))["L_tot"]
    assert rk4["physical"]["sho"] == pytest.approx(float(sho), rel=1e-12)


def test_report_shape_subsets_and_timings(evaluated):
    _, (results, _) = evaluated
    assert set(results["methods"]) == {"rk4_sensors_4", "paper_rk4", "dop853_sensors_1e-08", "net"}
    for name, m in results["methods"].items():
        assert REQUIRED <= set(m)
        assert {"mean", "std", "median", "iqr"} <= set(m["test"])
        assert set(m["physical"]) == {"sho", "double_well", "morse", "mff", "smff"}
        s = m["seconds_per_trajectory"]
        assert s["batch_1"] > 0 and s["batched"] > 0 and m["device"].startswith("cpu")
    assert results["methods"]["dop853_sensors_1e-08"]["test"]["n"] == 4  # unbatched: subset
    dop = results["methods"]["dop853_sensors_1e-08"]["seconds_per_trajectory"]
    assert dop["batched_size"] == 4 and dop["batched_repeats"] == 1
    assert results["methods"]["net"]["seconds_per_trajectory"]["batched_size"] == 8
    assert results["methods"]["net"]["kind"] == "neural"
    assert results["test_set"]["n"] == 24


def counting_rk4():
    """An RK4 method that records the batch size of every call it gets."""
    calls = []

    def run(V, t):
        calls.append(len(V))
        return nh.integrate_sensors(V, t, "rk4", 1)

    return {"rk4": ClassicalMethod("rk4", run, "rk4")}, calls


def test_cache_is_reused_and_refreshed_when_settings_change(testset, tmp_path):
    methods, calls = counting_rk4()
    settings = EvaluationSettings(timing=False)
    first, _ = evaluate_methods(methods, testset, settings, cache_dir=tmp_path, progress=False)
    n_calls = len(calls)
    assert n_calls == 6  # the test set and five physical potentials
    again, arrays = evaluate_methods(methods, testset, settings, cache_dir=tmp_path,
                                     progress=False)
    assert len(calls) == n_calls and again["methods"] == first["methods"]
    assert arrays["rk4"]["L_tot"].shape == (24,)
    evaluate_methods(methods, testset, EvaluationSettings(timing=False, n_single=3),
                     cache_dir=tmp_path, progress=False)
    assert len(calls) == 2 * n_calls
    assert not list(tmp_path.glob("*.tmp"))


def test_settings_and_empty_input_are_checked(testset):
    with pytest.raises(ValueError, match="repeats must be a positive integer"):
        EvaluationSettings(repeats=0)
    with pytest.raises(ValueError, match="at least one method"):
        evaluate_methods({}, testset)


def test_write_report_json_markdown_and_figures(testset, evaluated, tmp_path):
    _, (results, arrays) = evaluated
    path = write_report(results, arrays, testset, tmp_path, command="nh-operators evaluate x")
    text = path.read_text()
    for heading in ("## Test set", "## Physical potentials", "## Time per potential",
                    "## Speed and accuracy", "| Model | Mean L_tot | Std L_tot | Median L_tot"):
        assert heading in text
    m = results["methods"]["rk4_sensors_4"]["test"]
    assert f"| rk4_sensors_4 | {m['mean']:.4e} | {m['std']:.4e}" in text
    loaded = json.loads((tmp_path / "report.json").read_text())
    assert loaded["methods"]["net"]["test"]["mean"] == results["methods"]["net"]["test"]["mean"]
    for name in ("loss_histograms.png", "work_precision.png", "worst_net.png",
                 "physical_net_mff.png"):
        assert (tmp_path / name).stat().st_size > 5_000
    assert "(worst_net.png)" in text


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    root = tmp_path_factory.mktemp("cli")
    data, test, run = root / "d.h5", root / "t.h5", root / "run"
    assert main(["generate", "--size", "30", "--seed", "2", "--out", str(data), "--quiet"]) == 0
    assert main(["generate", "--size", "12", "--seed", "3", "--out", str(test), "--quiet"]) == 0
    assert main(["train", "--model", "deeponet", "--data", str(data), "--epochs", "1",
                 "--out", str(run), "--batch-size", "8", "--quiet", "--arch",
                 "hidden_size=8", "--arch", "branches=2"]) == 0
    return root


def test_cli_evaluate_writes_the_report(tiny_run, capsys):
    out = tiny_run / "report"
    args = ["evaluate", "--run", str(tiny_run / "run"), "--test", str(tiny_run / "t.h5"),
            "--out", str(out), "--classical", "rk4_sensors_1", "paper_rk4", "--repeats", "1",
            "--n-single", "2", "--batched-size", "6", "--quiet"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert "| deeponet |" in printed and "report.md" in printed
    report = json.loads((out / "report.json").read_text())
    assert set(report["methods"]) == {"deeponet", "rk4_sensors_1", "paper_rk4"}
    for m in report["methods"].values():
        assert REQUIRED <= set(m) and m["seconds_per_trajectory"]["batched_size"] == 6
    assert "stability" in report and "## Stability" in (out / "report.md").read_text()


def test_cli_benchmark_writes_the_work_precision_study(tiny_run, capsys):
    out = tiny_run / "bench"
    args = ["benchmark", "--run", str(tiny_run / "run"), "--test", str(tiny_run / "t.h5"),
            "--out", str(out), "--classical", "rk4_sensors_1", "rk4_sensors_4",
            "dop853_sensors_1e-06", "--unbatched-size", "3", "--repeats", "1",
            "--n-single", "2", "--batched-size", "6", "--quiet"]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert printed.count("deeponet (") == 2 and "faster than every classical method" in printed
    assert (out / "work_precision.png").stat().st_size > 5_000
    text = (out / "work_precision.md").read_text()
    assert "| dop853_sensors_1e-06 | classical | 3 |" in text
    assert json.loads((out / "work_precision.json").read_text())["test_set"]["n"] == 12


def test_cli_errors_are_clear(tiny_run, capsys):
    base = ["evaluate", "--test", str(tiny_run / "t.h5"), "--out", str(tiny_run / "e"),
            "--quiet", "--no-timing", "--no-figures", "--no-stability"]
    assert main(base + ["--run", str(tiny_run / "nope")]) == 2
    assert "nope" in capsys.readouterr().err
    assert main(base + ["--classical", "rk5"]) == 2
    assert "unknown classical method" in capsys.readouterr().err
    assert main(base[:1] + ["--test", str(tiny_run / "missing.h5")] + base[3:]) == 2


def test_fresh_recomputes(testset, tmp_path):
    methods, calls = counting_rk4()
    settings = EvaluationSettings(timing=False)
    for fresh in (False, False, True):
        evaluate_methods(methods, testset, settings, cache_dir=tmp_path, fresh=fresh,
                         progress=False)
    assert len(calls) == 12  # computed, reused, recomputed


def test_a_method_returning_nan_is_reported_not_fatal(testset, tmp_path):
    def broken(V, t):
        q, p = nh.integrate_sensors(V, t, "rk4", 1)
        q[::2] = np.nan
        return q, p

    methods = {"broken": ClassicalMethod("broken", broken, "broken")}
    results, arrays = evaluate_methods(methods, testset, EvaluationSettings(timing=False),
                                       progress=False)
    test = results["methods"]["broken"]["test"]
    assert test["n_nonfinite"] == 12 and test["n"] == 24 and np.isfinite(test["mean"])
    assert int(arrays["broken"]["worst"]) == 0  # the first non-finite sample
    everything = {"broken": ClassicalMethod(
        "broken", lambda V, t: (np.full((len(V), len(t)), np.nan),) * 2, "broken")}
    results, _ = evaluate_methods(everything, testset, EvaluationSettings(timing=False),
                                  progress=False)
    assert results["methods"]["broken"]["test"]["n_nonfinite"] == 24
    write_report(results, _, testset, tmp_path, figures=False)
    saved = json.loads((tmp_path / "report.json").read_text())
    assert saved["methods"]["broken"]["test"]["mean"] is None
