import pytest

from nh_operators.cli import main
from nh_operators.data import load_dataset


def test_generate_prints_counts_and_writes_a_loadable_file(tmp_path, capsys):
    out = tmp_path / "tiny.h5"
    assert main(["generate", "--size", "12", "--seed", "3", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "12 potentials (seed 3)" in text and "dropped 0" in text and "sha256:" in text
    ds = load_dataset(out)
    assert len(ds) == 12 and ds.attrs["seed"] == 3


def test_generate_preset_with_size_override(tmp_path, capsys):
    out = tmp_path / "t.h5"
    assert main(["generate", "--preset", "test", "--size", "5", "--out", str(out), "--quiet"]) == 0
    assert load_dataset(out).attrs["seed"] == 42


def test_generate_needs_arguments():
    with pytest.raises(SystemExit, match="give --preset"):
        main(["generate", "--size", "3"])


def test_generate_bad_size_is_a_clear_error(tmp_path, capsys):
    assert main(["generate", "--size", "0", "--seed", "1", "--out", str(tmp_path / "x.h5")]) == 2
    assert "positive integer" in capsys.readouterr().err


def test_demo_prints_table_and_writes_figure(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    for name in ("sho", "double_well", "morse", "mff", "smff", "paper_rk4", "rk4_sensors_4"):
        assert name in text
    # the RK4 row on sensors at 4 substeps beats the paper's replica on the SHO
    rows = {line.split()[0]: line.split()[1:] for line in text.splitlines() if line[:1].isalpha()}
    assert float(rows["rk4_sensors_4"][0]) < 1e-3 * float(rows["paper_rk4"][0])
    assert (tmp_path / "physical_potentials.png").stat().st_size > 10_000


def test_train_writes_a_run_directory_and_resumes(tmp_path, capsys):
    data = tmp_path / "d.h5"
    assert main(["generate", "--size", "40", "--seed", "2", "--out", str(data),
                 "--quiet"]) == 0
    run = tmp_path / "run"
    args = ["train", "--model", "deeponet", "--data", str(data), "--epochs", "2",
            "--seed", "1", "--out", str(run), "--batch-size", "16", "--quiet",
            "--arch", "hidden_size=16", "--arch", "branches=4"]
    assert main(args) == 0
    text = capsys.readouterr().out
    assert "deeponet (cpu," in text and "2 epochs" in text
    assert {p.name for p in run.iterdir()} == {"checkpoint.pt", "config.json",
                                               "history.csv"}
    assert main(args) == 2
    assert "--resume" in capsys.readouterr().err
    assert main(args + ["--resume"]) == 0  # already complete: nothing left to do
    assert main(args[:-4] + ["--arch", "widht=3", "--out", str(tmp_path / "r2")]) == 2
    assert "no argument(s) ['widht']" in capsys.readouterr().err
