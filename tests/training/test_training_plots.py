import numpy as np
import pytest

from nh_operators.training import plot_training_curves, read_history


def write_history(path, rows):
    path.mkdir()
    lines = ["epoch,train_loss,val_loss,lr,seconds"]
    lines += [f"{e},{tr},{va},1e-3,{s}" for e, tr, va, s in rows]
    (path / "history.csv").write_text("\n".join(lines) + "\n")
    return path


def test_curves_are_the_history_against_minutes(tmp_path):
    run = write_history(tmp_path / "a", [(1, 0.5, 0.4, 30), (2, 0.2, 0.1, 60), (3, 0.1, 0.05, 90)])
    h = read_history(run)
    np.testing.assert_array_equal(h["epoch"], [1, 2, 3])
    fig = plot_training_curves({"a": run}, goals={"paper": 0.01}, title="t")
    (ax,) = fig.axes
    val, train, solid_key, dashed_key, goal = ax.lines
    assert solid_key.get_xdata().size == dashed_key.get_xdata().size == 0  # legend keys only
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "a", "validation (solid)", "training (dashed)", "paper"]
    np.testing.assert_allclose(val.get_xdata(), [0.5, 1.0, 1.5])
    np.testing.assert_array_equal(val.get_ydata(), [0.4, 0.1, 0.05])
    np.testing.assert_array_equal(train.get_ydata(), [0.5, 0.2, 0.1])
    assert goal.get_ydata()[0] == 0.01 and ax.get_yscale() == "log"


def test_errors(tmp_path):
    with pytest.raises(ValueError, match="no runs"):
        plot_training_curves({})
    empty = write_history(tmp_path / "e", [])
    with pytest.raises(ValueError, match="holds no epochs"):
        read_history(empty)
    with pytest.raises(FileNotFoundError):
        read_history(tmp_path / "missing")


def test_minutes_to_reach_extrapolates_a_power_law_and_sees_a_plateau():
    from nh_operators.training import minutes_to_reach

    m = np.linspace(1, 20, 20)
    minutes, slope = minutes_to_reach({"seconds": 60 * m, "val_loss": 0.5 * m**-2.0}, 5e-5)
    assert slope == pytest.approx(-2.0) and minutes == pytest.approx(100.0)
    # already reached: the first time it was
    assert minutes_to_reach({"seconds": 60 * m, "val_loss": 0.5 * m**-2.0}, 0.1)[0] == 3.0
    flat = {"seconds": 60 * m, "val_loss": np.full(20, 0.01)}
    assert minutes_to_reach(flat, 1e-3) == (float("inf"), pytest.approx(0.0, abs=1e-12))
