import re

import numpy as np
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


def test_generate_needs_arguments(capsys):
    assert main(["generate", "--size", "3"]) == 2
    assert "give --preset, or all of --size, --seed and --out (missing: --seed, --out)" \
        in capsys.readouterr().err


def test_generate_bad_size_is_a_clear_error(tmp_path, capsys):
    assert main(["generate", "--size", "0", "--seed", "1", "--out", str(tmp_path / "x.h5")]) == 2
    assert "argument --size: must be a positive integer, got 0" in capsys.readouterr().err


def test_demo_prints_table_and_writes_figure(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    for name in ("sho", "double_well", "morse", "mff", "smff", "paper_rk4", "rk4_sensors_4"):
        assert name in text
    # the RK4 row on sensors at 4 substeps beats the paper's replica on the SHO
    rows = {line.split()[0]: line.split()[1:] for line in text.splitlines() if line[:1].isalpha()}
    assert float(rows["rk4_sensors_4"][0]) < 1e-3 * float(rows["paper_rk4"][0])
    assert (tmp_path / "physical_potentials.png").stat().st_size > 10_000
    # every shipped network has a row; on the SHO each is within 1e-1 and not exact; the
    # state networks, which compute the orbit's shape by quadrature, within 1e-8
    import nh_operators as nh

    for name in nh.available_pretrained():
        assert 0 < float(rows[name][0]) < (1e-8 if name.endswith("-states") else 1e-1)
    assert len(list(tmp_path.glob("double_well_*.png"))) == 1
    # the table is written as Markdown too: cost per trajectory in a batch, its size in
    # the header, and the same L_tot as printed
    table = (tmp_path / "table.md").read_text(encoding="utf-8").splitlines()
    header = next(line for line in table if line.startswith("| method |"))
    assert header.endswith("| µs / trajectory, batch 200 |")
    assert "median of 3 calls after a warm-up" in "\n".join(table)
    md = {cells[0]: cells[1:] for cells in (
        [c.strip() for c in line.strip("|").split("|")] for line in table
        if line.startswith("| ") and not line.startswith("| method"))}
    from nh_operators.evaluation import CLASSICAL_BASELINES

    assert set(md) == {*CLASSICAL_BASELINES, *nh.available_pretrained(), "rk4_exact_16"}
    assert float(md["paper_rk4"][0]) == pytest.approx(float(rows["paper_rk4"][0]), rel=1e-2)
    assert all(float(cells[-1].replace(",", "")) > 0 for cells in md.values())


def test_help_speaks_to_users(capsys):
    assert main(["--help"]) == 0
    text = capsys.readouterr().out
    assert ":func:" not in text and "``" not in text and ":class:" not in text
    for command in ("demo", "predict", "generate", "train", "evaluate", "benchmark"):
        assert f"\n    {command}" in text
    assert 'nh-operators predict --potential "8*(q-0.5)**2"' in text


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


def test_predict_prints_the_table_and_writes_the_figure(tmp_path, capsys):
    fig = tmp_path / "fig.png"
    assert main(["predict", "--model", "deeponet", "--potential", "8*(q-0.5)**2",
                 "--times", "0.5", "1.0", "1.5", "--out", str(fig)]) == 0
    out = capsys.readouterr().out
    assert "V(q) = 8*(q-0.5)**2" in out and "method: deeponet-alg1 (neural; forced)" in out
    rows = [line.split() for line in out.splitlines() if re.match(r"\s+\d", line)]
    assert [r[0] for r in rows] == ["0.5000", "1.0000", "1.5000"]
    # the SHO in disguise: q(t) = (1 - cos 4t) / 2; DeepONet is within a few 1e-2
    for r in rows:
        assert abs(float(r[1]) - (1 - np.cos(4 * float(r[0]))) / 2) < 0.1
    assert fig.stat().st_size > 10_000 and fig.read_bytes()[:4] == b"\x89PNG"


def test_predict_with_tol_uses_the_classical_solver_beyond_t_2(capsys):
    assert main(["predict", "--potential", "sho", "--times", "0.5", "3.0",
                 "--tol", "1e-8"]) == 0
    out = capsys.readouterr().out
    assert "method: rk4 (classical" in out and "tol 1e-08" in out
    q = [float(line.split()[1]) for line in out.splitlines() if re.match(r"\s+\d", line)]
    np.testing.assert_allclose(q, (1 - np.cos(4 * np.array([0.5, 3.0]))) / 2, atol=1e-4)


@pytest.mark.parametrize("expr, message", [
    ("__import__('os').system('ls')", "cannot use .__import__.*not an allowed function"),
    ("q**2", r"V\(0\) = 0, but a bounded potential needs"),
    ("2 - q*(1-q) +", "invalid syntax"),
])
def test_predict_rejects_unsafe_or_unbounded_potentials(expr, message, capsys):
    assert main(["predict", "--potential", expr]) == 2
    assert re.search(message, capsys.readouterr().err)
