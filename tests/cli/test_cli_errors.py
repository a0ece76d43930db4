"""Every subcommand with each bad argument: exit 2 and one ``error:`` line, no traceback.

The sweep runs ``main`` in-process (an exception that escaped would fail the test); a
few cases also run as real processes, to see exactly what a user's terminal shows.
"""

import os
import subprocess
import sys

import pytest

import nh_operators as nh
from nh_operators.cli import main
from nh_operators.cli.generate import PRESETS as CLI_PRESETS
from nh_operators.cli.training import MODEL_NAMES
from nh_operators.data import DATASET_PRESETS as PRESETS, generate_dataset


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "d.h5"
    generate_dataset(12, seed=3, path=path, progress=False)
    return path


def _cases(tmp, data):
    d, out = str(data), str(tmp / "o")
    return {
        # generate
        "generate --out dir": (["generate", "--size", "5", "--seed", "1", "--out", str(tmp)],
                               "is a directory; give a file name"),
        "generate --chunk 0": (["generate", "--size", "5", "--seed", "1", "--out",
                                str(tmp / "a.h5"), "--chunk", "0"],
                               "argument --chunk: must be a positive integer, got 0"),
        "generate --chunk -3": (["generate", "--size", "5", "--seed", "1", "--out",
                                 str(tmp / "a.h5"), "--chunk", "-3"],
                                "argument --chunk: must be a positive integer, got -3"),
        "generate --seed abc": (["generate", "--size", "5", "--seed", "abc", "--out", "a.h5"],
                                "argument --seed: expected an integer, got 'abc'"),
        "generate --seed -1": (["generate", "--size", "5", "--seed", "-1", "--out", "a.h5"],
                               "argument --seed: must be a non-negative integer, got -1"),
        "generate missing": (["generate", "--size", "5"], "missing: --seed, --out"),
        "generate no folder": (["generate", "--size", "5", "--seed", "1", "--out",
                                str(tmp / "no" / "a.h5")], "does not exist"),
        "generate existing": (["generate", "--size", "5", "--seed", "1", "--out", d],
                              "already exists; pass force=True (--force)"),
        "generate share without states": (["generate", "--size", "5", "--seed", "1", "--out",
                                           str(tmp / "s.h5"), "--separatrix-share", "0.5"],
                                          "--separatrix-share needs --states energy"),
        "generate share 2": (["generate", "--size", "5", "--seed", "1", "--out",
                              str(tmp / "s.h5"), "--states", "energy", "--separatrix-share",
                              "2"], "separatrix_share must be in [0, 1], got 2.0"),
        # train and tune
        "train --data dir": (["train", "--model", "deeponet", "--data", str(tmp), "--out", out],
                             f"argument --data: {str(tmp)!r} is a directory; give a file"),
        "train --data missing": (["train", "--model", "deeponet", "--data", "nope.h5",
                                  "--out", out], "argument --data: no file 'nope.h5'"),
        "train truncated": (["train", "--model", "deeponet", "--data", str(tmp / "cut.h5"),
                             "--out", out], "it may be truncated"),
        "train --epochs 0": (["train", "--model", "deeponet", "--data", d, "--out", out,
                              "--epochs", "0"], "argument --epochs: must be a positive integer"),
        "train --model": (["train", "--model", "resnet", "--data", d, "--out", out],
                          "argument --model: invalid choice: 'resnet'"),
        "train --ema 1": (["train", "--model", "traonet", "--data", d, "--out", out,
                           "--ema", "1"], "argument --ema: must lie in [0, 1), got '1'"),
        "train --loss": (["train", "--model", "traonet", "--data", d, "--out", out,
                          "--loss", "l1"], "argument --loss: invalid choice: 'l1'"),
        "train --lr": (["train", "--model", "deeponet", "--data", d, "--out", out, "--lr",
                        "-1"], "argument --lr: must be positive, got '-1'"),
        "tune --trials 0": (["tune", "--model", "deeponet", "--stage", "grid", "--data", d,
                             "--trials", "0"], "argument --trials: must be a positive integer"),
        # evaluate, benchmark, export, calibrate
        "evaluate --test": (["evaluate", "--test", "nope.h5", "--out", out],
                            "argument --test: no file 'nope.h5'"),
        "evaluate --run": (["evaluate", "--test", d, "--out", out, "--run", "nope"],
                           "argument --run: no directory 'nope'"),
        "benchmark --repeats": (["benchmark", "--test", d, "--out", out, "--repeats", "0"],
                                "argument --repeats: must be a positive integer"),
        "export --run": (["export", "--run", "nope", "--out", out],
                         "argument --run: no directory 'nope'"),
        "calibrate --data": (["calibrate", "--model", "deeponet", "--data", str(tmp)],
                             "is a directory; give a file"),
        # predict
        "predict --rows -3": (["predict", "--potential", "sho", "--rows", "-3"],
                              "argument --rows: must be a positive integer, got -3"),
        "predict --out .xyz": (["predict", "--potential", "sho", "--out", str(tmp / "f.xyz")],
                               "cannot write a figure as '.xyz'"),
        "predict --tol": (["predict", "--potential", "sho", "--tol", "0"],
                          "argument --tol: must be positive, got '0'"),
        "predict singular": (["predict", "--potential", "2-(q*(1-q))**0.5", "--times", "0.5"],
                             "V'(q) is not finite at q = 0"),
        "predict unknown model": (["predict", "--potential", "sho", "--model", "nope"],
                                  "unknown method 'nope'"),
        # no subcommand, unknown flag
        "no command": ([], "the following arguments are required: COMMAND"),
        "unknown flag": (["generate", "--sizes", "5"], "unrecognized arguments: --sizes"),
    }


def test_every_bad_argument_is_one_error_line_and_exit_2(tmp_path, data, capsys):
    (tmp_path / "cut.h5").write_bytes(data.read_bytes()[:1000])
    failures = []
    for label, (argv, message) in _cases(tmp_path, data).items():
        code = main(argv)
        err = capsys.readouterr().err.strip()
        lines = err.splitlines()
        if code != 2 or len(lines) != 1 or "error:" not in err or message not in err:
            failures.append(f"{label}: exit {code}, stderr {err!r}")
    assert not failures, "\n".join(failures)


def test_a_real_process_prints_no_traceback(tmp_path):
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    for argv in (["generate", "--chunk", "0", "--size", "3", "--seed", "1", "--out", "x.h5"],
                 ["predict", "--potential", "2-(q*(1-q))**0.5", "--times", "0.5"]):
        code = "import sys; from nh_operators.cli import main; sys.exit(main(sys.argv[1:]))"
        res = subprocess.run([sys.executable, "-c", code, *argv], env=env,
                             capture_output=True, text=True, cwd=tmp_path, timeout=120)
        assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1 and "error:" in res.stderr


def test_generate_help_says_which_flags_are_required(capsys):
    assert main(["generate", "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "Give --preset NAME, or all three of --size, --seed and --out" in text
    assert "(required without --preset)" in text


def test_an_explicit_flag_says_it_overrides_the_preset(tmp_path, capsys):
    out = tmp_path / "t.h5"
    assert main(["generate", "--preset", "test", "--size", "10", "--out", str(out),
                 "--quiet"]) == 0
    assert "note: --size 10 overrides the test preset's 4000" in capsys.readouterr().err


def test_a_states_preset_draws_states_for_the_same_potentials(tmp_path, capsys):
    out, plain = tmp_path / "s.h5", tmp_path / "p.h5"
    assert main(["generate", "--preset", "paper-states-test", "--size", "6", "--out",
                 str(out), "--quiet"]) == 0
    assert main(["generate", "--preset", "paper-test", "--size", "6", "--out", str(plain),
                 "--quiet"]) == 0
    with_states, without = nh.load_dataset(out), nh.load_dataset(plain)
    assert with_states.attrs["states"]["distribution"] == "energy"
    assert with_states.q0.shape == (6,) and without.q0 is None
    assert (with_states.V == without.V).all()


def test_force_replaces_a_finished_file(tmp_path, capsys):
    out = tmp_path / "t.h5"
    assert main(["generate", "--size", "5", "--seed", "1", "--out", str(out), "--quiet"]) == 0
    assert main(["generate", "--size", "6", "--seed", "1", "--out", str(out), "--quiet"]) == 2
    assert main(["generate", "--size", "6", "--seed", "1", "--out", str(out), "--quiet",
                 "--force"]) == 0
    assert "wrote" in capsys.readouterr().out


def test_ctrl_c_in_generate_says_what_was_kept_and_how_to_resume(tmp_path, capsys,
                                                                 monkeypatch):
    import nh_operators.data.generate as generate_module

    original, calls = generate_module.SampleSource.take, {"n": 0}

    def interrupted(self, n, drops=None):
        calls["n"] += 1
        if calls["n"] > 1:
            raise KeyboardInterrupt
        return original(self, n, drops)

    monkeypatch.setattr(generate_module.SampleSource, "take", interrupted)
    out = tmp_path / "c.h5"
    argv = ["generate", "--size", "30", "--seed", "2", "--chunk", "10", "--out", str(out),
            "--quiet"]
    assert main(argv) == 130
    assert capsys.readouterr().err.strip() == (
        f"nh-operators generate: interrupted; 10 of 30 potentials kept in {out}.partial; "
        "run the same command again to resume")
    monkeypatch.setattr(generate_module.SampleSource, "take", original)
    assert main(argv) == 0
    assert generate_dataset(30, seed=2, progress=False).attrs["n_dropped"] == \
        nh.load_dataset(out).attrs["n_dropped"]


def test_ctrl_c_in_train_says_which_epoch_is_kept(tmp_path, data, capsys, monkeypatch):
    run = tmp_path / "run"
    base = ["train", "--model", "deeponet", "--data", str(data), "--out", str(run), "--quiet",
            "--arch", "hidden_size=8", "--arch", "hidden_layers=1", "--arch", "branches=2"]
    assert main(base + ["--epochs", "1"]) == 0

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    import nh_operators.training

    monkeypatch.setattr(nh_operators.training, "train", interrupted)
    assert main(base + ["--epochs", "3", "--resume"]) == 130
    assert capsys.readouterr().err.strip() == (
        f"nh-operators train: interrupted; the checkpoint of epoch 1 is kept in {run}; add "
        "--resume to the same command to continue")


def test_the_cli_lists_agree_with_the_library():
    assert sorted(MODEL_NAMES) == sorted(nh.MODELS)
    assert CLI_PRESETS == PRESETS
