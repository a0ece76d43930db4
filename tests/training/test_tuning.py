"""Tuning: two worker processes on one SQLite study, pruning, the best configuration
into ``train --config``, the search spaces and the errors."""

import json
import subprocess
import sys

import optuna
import pytest
from model_helpers import TINY

from nh_operators.cli import main
from nh_operators.data import generate_dataset
from nh_operators.training import (
    SEARCH_SPACES,
    TrialReporter,
    best_config,
    get_space,
    grid_size,
    load_tuned_config,
    open_study,
    tune,
    tuned_train_kwargs,
)

GRID = {"hidden_size": [8, 16], "hidden_layers": [1, 2], "branches": [2, 4]}
SPACE = {
    "preset": "cpu", "epochs": 2, "seeds": 2, "batch_size": 16,
    "pruner": {"n_startup_trials": 2, "n_warmup_steps": 0},
    "grid": {"deeponet": GRID},
    "schedule": {"deeponet": {"lr": 1e-2, "upper_bound": 300, "infimum_lr": 1e-4}},
    "tpe": {"deeponet": {"lr": {"low": 1e-7, "high": 1e-1, "log": True},
                         "upper_bound": [300, 400],
                         "infimum_lr": {"low": 1e-9, "high": 1e-4, "log": True}}},
}


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    path = tmp_path_factory.mktemp("tune") / "d.h5"
    generate_dataset(60, seed=3, path=path, progress=False)
    return path


@pytest.fixture(scope="module")
def grid_study(data, tmp_path_factory):
    """Two `nh-operators tune` processes started together on one SQLite study, four
    trials each of the 8-point grid."""
    tmp = tmp_path_factory.mktemp("grid")
    space = tmp / "tiny.json"
    space.write_text(json.dumps(SPACE))
    url, best = f"sqlite:///{tmp / 'tune.db'}", tmp / "best.json"
    cmd = [sys.executable, "-m", "nh_operators.cli.main", "tune", "--model", "deeponet",
           "--stage", "grid", "--trials", "4", "--storage", url, "--data", str(data),
           "--space", str(space), "--out", str(best), "--workdir", str(tmp / "runs"),
           "--threads", "1"]
    workers = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True) for _ in range(2)]
    outputs = [w.communicate(timeout=300) for w in workers]
    for w, (out, err) in zip(workers, outputs):
        assert w.returncode == 0, err
    return url, best, space, [out for out, _ in outputs]


def test_two_worker_processes_split_the_grid_of_one_sqlite_study(grid_study, data, capsys):
    url, best, space, outputs = grid_study
    study = optuna.load_study(study_name="deeponet-grid-tiny", storage=url)
    trials = study.trials
    assert len(trials) == 8
    assert {t.state for t in trials} <= {optuna.trial.TrialState.COMPLETE,
                                         optuna.trial.TrialState.PRUNED}
    points = [tuple(sorted(t.params.items())) for t in trials]
    assert len(set(points)) == 8 == grid_size(SPACE, "deeponet")  # the grid, no repeats
    assert len({t.user_attrs["worker"] for t in trials}) == 2  # both processes worked
    for out in outputs:  # one progress line per trial, with the best so far
        lines = [line for line in out.splitlines() if "| best" in line]
        assert len(lines) == 4 and "deeponet-grid-tiny: best trial" in out
    complete = [t for t in trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert all(len(t.user_attrs["val_losses"]) == 2 for t in complete)  # seeds averaged
    runs = space.parent / "runs" / "deeponet-grid-tiny"  # --workdir keeps every run
    for t in complete:
        for seed in (0, 1):
            assert (runs / f"trial-{t.number:05d}" / f"seed-{seed}" / "checkpoint.pt").is_file()
    written = json.loads(best.read_text())
    winner = min(complete, key=lambda t: t.value)
    assert written["tuning"]["trial"] == winner.number
    assert written["tuning"]["value"] == pytest.approx(winner.value)
    assert written["arch"] == {k: winner.params[k] for k in GRID}
    assert best_config(study) == written
    # a worker joining a finished grid has nothing to do; other settings are refused
    assert main(["tune", "--model", "deeponet", "--stage", "grid", "--storage", url,
                 "--data", str(data), "--space", str(space), "--out", str(best)]) == 0
    assert "every point of the 8-point grid is taken" in capsys.readouterr().out
    assert len(optuna.load_study(study_name="deeponet-grid-tiny", storage=url).trials) == 8
    assert main(["tune", "--model", "deeponet", "--stage", "grid", "--storage", url,
                 "--data", str(data), "--space", str(space), "--epochs", "3"]) == 2
    assert "other settings (they differ in ['epochs'])" in capsys.readouterr().err


def test_best_config_round_trips_into_train_config(grid_study, data, tmp_path, capsys):
    _, best, _, _ = grid_study
    written = json.loads(best.read_text())
    run = tmp_path / "run"
    assert main(["train", "--config", str(best), "--data", str(data), "--epochs", "1",
                 "--batch-size", "16", "--out", str(run), "--quiet"]) == 0
    config = json.loads((run / "config.json").read_text())
    for key in ("model", "preset", "arch", "lr", "upper_bound", "infimum_lr"):
        assert config[key] == written[key], key
    assert config["lr"] == 1e-2 and config["infimum_lr"] == 1e-4  # the grid's schedule
    # explicit flags win; --arch replaces one key and keeps the file's others
    run2 = tmp_path / "run2"
    assert main(["train", "--config", str(best), "--data", str(data), "--epochs", "1",
                 "--batch-size", "16", "--out", str(run2), "--quiet", "--lr", "5e-3",
                 "--arch", "branches=3", "--preset", "paper"]) == 0
    config = json.loads((run2 / "config.json").read_text())
    assert config["lr"] == 5e-3 and config["preset"] == "paper"
    assert config["arch"] == {**written["arch"], "branches": 3}
    assert config["infimum_lr"] == written["infimum_lr"]
    capsys.readouterr()
    assert main(["train", "--config", str(best), "--model", "traonet", "--data", str(data),
                 "--out", str(tmp_path / "r3")]) == 2
    assert "the config file is for 'deeponet', not 'traonet'" in capsys.readouterr().err


def test_an_obviously_bad_learning_rate_is_pruned_after_its_first_epoch(data, tmp_path):
    url = f"sqlite:///{tmp_path / 'p.db'}"
    pruner = optuna.pruners.MedianPruner(n_startup_trials=1, n_warmup_steps=0)
    study = open_study("deeponet", "tpe", storage=url, space=SPACE, pruner=pruner)
    study.enqueue_trial({"lr": 1e-2, "upper_bound": 300, "infimum_lr": 1e-4})
    study.enqueue_trial({"lr": 1e-7, "upper_bound": 300, "infimum_lr": 1e-9})  # frozen
    study = tune("deeponet", "tpe", data, n_trials=2, storage=url, space=SPACE,
                 pruner=pruner, base={"arch": TINY["deeponet"]}, progress=False,
                 out=tmp_path / "best.json")
    good, bad = study.trials
    assert good.state == optuna.trial.TrialState.COMPLETE
    assert sorted(good.intermediate_values) == [0, 1, 2, 3]  # 2 seeds x 2 epochs
    assert good.value == pytest.approx(good.intermediate_values[3])
    assert bad.state == optuna.trial.TrialState.PRUNED
    assert list(bad.intermediate_values) == [0]  # stopped after one epoch of one seed
    assert bad.intermediate_values[0] > good.intermediate_values[0]
    written = load_tuned_config(tmp_path / "best.json")
    assert written["lr"] == 1e-2 and written["arch"] == TINY["deeponet"]


def test_trial_reporter_steps_running_means_and_raises_when_told():
    class FakeTrial:
        def __init__(self):
            self.reports = []

        def report(self, value, step):
            self.reports.append((step, value))

        def should_prune(self):
            return self.reports[-1][0] == 4

    trial = FakeTrial()
    reporter = TrialReporter(trial, epochs=3, n_seeds=2)
    for epoch, loss in ((1, 4.0), (2, 2.0), (3, 1.0)):
        reporter.callback(0)({"epoch": epoch, "val_loss": loss}, None)
    reporter.callback(1)({"epoch": 1, "val_loss": 2.0}, None)
    with pytest.raises(optuna.TrialPruned, match="seed index 1, epoch 2"):
        reporter.callback(1)({"epoch": 2, "val_loss": 1.0}, None)
    assert trial.reports == [(0, 4.0), (1, 2.0), (2, 1.0), (3, 3.0), (4, 1.5)]


def test_search_spaces_hold_the_papers_tables():
    paper, cpu = get_space("paper"), get_space("cpu")
    assert set(SEARCH_SPACES) == {"paper", "cpu"}
    assert [grid_size(paper, m) for m in ("deeponet", "traonet", "varonet", "mambonet")] \
        == [64, 81, 48, 243]
    assert paper["epochs"] == 50 and paper["seeds"] == 5
    assert paper["grid"]["traonet"]["dim_feedforward"] == [512, 1024, 2048]
    assert paper["tpe"]["varonet"]["beta"] == {"low": 1e-3, "high": 1.0, "log": True}
    assert paper["tpe"]["deeponet"]["lr"] == {"low": 1e-3, "high": 1e-1, "log": True}
    assert paper["tpe"]["mambonet"]["upper_bound"] == [300, 350, 400]
    assert paper["schedule"]["deeponet"] == {"lr": 1e-2, "upper_bound": 300,
                                             "infimum_lr": 1e-5}
    for space in (paper, cpu):
        for model, grid in space["grid"].items():
            heads = grid.get("nhead", [1])
            assert all(d % h == 0 for d in grid.get("d_model", [0]) for h in heads), model
    assert all(grid_size(cpu, m) <= 16 for m in cpu["grid"])


def test_unknown_model_stage_space_and_a_rejected_storage_are_clear_errors(data, tmp_path,
                                                                          capsys):
    url = f"sqlite:///{tmp_path / 'e.db'}"
    with pytest.raises(ValueError, match="unknown model 'nope'"):
        tune("nope", "grid", data, storage=url)
    with pytest.raises(ValueError, match="unknown stage 'random'"):
        tune("deeponet", "random", data, storage=url)
    with pytest.raises(ValueError, match="unknown search space 'huge'"):
        tune("deeponet", "grid", data, storage=url, space="huge")
    with pytest.raises(ValueError, match="needs n_trials or a timeout"):
        tune("deeponet", "tpe", data, storage=url)
    with pytest.raises(ValueError, match="no tpe stage for 'traonet'"):
        tune("traonet", "tpe", data, storage=url, space=SPACE, n_trials=1)
    with pytest.raises(ValueError, match="optuna rejected the storage URL"):
        tune("deeponet", "grid", data, storage="nosuchdb://nowhere/x")
    base = ["tune", "--model", "deeponet", "--stage", "grid", "--data", str(data)]
    assert main(base + ["--storage", url, "--space", "huge"]) == 2
    assert "unknown search space 'huge'" in capsys.readouterr().err
    assert main(base + ["--storage", f"sqlite:///{tmp_path}/missing/dir/x.db"]) == 2
    assert "optuna rejected the storage URL" in capsys.readouterr().err
    assert main(["tune", "--model", "nope", "--stage", "grid", "--data", str(data)]) == 2
    assert "invalid choice: 'nope'" in capsys.readouterr().err
    assert main(base[:4] + ["random", "--data", str(data)]) == 2
    assert "invalid choice: 'random'" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"model": "deeponet", "epochs": 250}))
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['epochs'\]"):
        load_tuned_config(bad)
    with pytest.raises(ValueError, match="give a model"):
        tuned_train_kwargs(None, lr=1e-3)


def test_an_interrupted_grid_trial_is_queued_again(data, tmp_path, monkeypatch):
    import nh_operators.training.tuning as tuning

    space = {**SPACE, "epochs": 1, "seeds": 1,
             "grid": {"deeponet": {**GRID, "hidden_size": [8], "hidden_layers": [1]}}}
    url = f"sqlite:///{tmp_path / 'i.db'}"
    train = tuning.train

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(tuning, "train", interrupted)
    with pytest.raises(KeyboardInterrupt):
        tune("deeponet", "grid", data, storage=url, space=space, progress=False)
    monkeypatch.setattr(tuning, "train", train)
    study = tune("deeponet", "grid", data, storage=url, space=space, progress=False)
    states = [t.state.name for t in study.trials]
    assert states == ["FAIL", "COMPLETE", "COMPLETE"]
    assert study.trials[0].params == study.trials[1].params  # the queued point
    assert {t.params["branches"] for t in study.trials[1:]} == {2, 4}


def test_a_trial_started_past_the_grids_end_is_recognised_as_extra():
    from nh_operators.training.tuning import _extra_grid_trial, _grid_left

    study = open_study("deeponet", "grid", storage=optuna.storages.InMemoryStorage(),
                       space={**SPACE, "grid": {"deeponet": {"branches": [2, 4]}}})
    first, second = study.ask(), study.ask()  # both points running
    assert _grid_left(study.trials, 2) == 0
    late = study.ask()  # a third worker: Optuna hands out a running point again
    assert not _extra_grid_trial(first) and not _extra_grid_trial(second)
    assert _extra_grid_trial(late)
