import io

import numpy as np
import pytest

from nh_operators import PHYSICAL_POTENTIALS, SENSORS, TIMES
from nh_operators.evaluation import (
    log_bins,
    plot_loss_histograms,
    plot_physical_potentials,
    plot_trajectory,
    plot_work_precision,
    plot_worst_sample,
)

SHO = PHYSICAL_POTENTIALS["sho"]


@pytest.fixture(scope="module")
def sho_traj():
    return SHO.exact(TIMES)


def _render(fig):
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=40)
    return buf.tell()


# ------------------------------------------------------------------ plot_trajectory


def test_trajectory_panels_hold_the_inputs(sho_traj):
    q, p = sho_traj
    qp, pp = q + 0.01, p - 0.02
    fig = plot_trajectory(SHO, TIMES, q, p, qp, pp, title="SHO")
    assert len(fig.axes) == 5  # V, q(t), p(t), phase portrait, colorbar
    ax_v, ax_q, ax_p, ax_ph, cbar = fig.axes
    grid = ax_v.lines[0].get_xdata()
    np.testing.assert_array_equal(ax_v.lines[0].get_ydata(), SHO.V(grid))
    assert grid[0] == 0.0 and grid[-1] == 1.0
    for ax, truth, pred in ((ax_q, q, qp), (ax_p, p, pp)):
        np.testing.assert_array_equal(ax.lines[0].get_xdata(), TIMES)
        np.testing.assert_array_equal(ax.lines[0].get_ydata(), truth)
        (points,) = ax.collections
        np.testing.assert_array_equal(points.get_offsets(), np.column_stack([TIMES, pred]))
        np.testing.assert_array_equal(points.get_array(), TIMES)  # coloured by time
    truth_ph, pred_ph = ax_ph.collections
    segments = truth_ph.get_segments()
    assert len(segments) == TIMES.size - 1
    np.testing.assert_array_equal(segments[0], [[q[0], p[0]], [q[1], p[1]]])
    np.testing.assert_allclose(truth_ph.get_array(), 0.5 * (TIMES[1:] + TIMES[:-1]))
    np.testing.assert_array_equal(pred_ph.get_offsets(), np.column_stack([qp, pp]))
    assert cbar.get_ylabel() == "t"
    # one shared time scale for every coloured artist
    norms = {id(c.norm) for ax in (ax_q, ax_p, ax_ph) for c in ax.collections}
    assert len(norms) == 1
    assert (truth_ph.norm.vmin, truth_ph.norm.vmax) == (TIMES[0], TIMES[-1])
    assert fig.get_suptitle() == "SHO"
    assert _render(fig) > 1000


def test_trajectory_without_prediction(sho_traj):
    fig = plot_trajectory(SHO, TIMES, *sho_traj)
    ax_v, ax_q, ax_p, ax_ph, _ = fig.axes
    assert len(ax_q.collections) == len(ax_p.collections) == 0
    assert len(ax_ph.collections) == 1


def test_trajectory_accepts_sensor_values(sho_traj):
    values = SHO.V(SENSORS)
    fig = plot_trajectory(values, TIMES, *sho_traj)
    line = fig.axes[0].lines[0]
    np.testing.assert_array_equal(line.get_xdata(), SENSORS)
    np.testing.assert_array_equal(line.get_ydata(), values)
    assert line.get_marker() == "o"


@pytest.mark.parametrize("args, match", [
    ((TIMES, TIMES[:-1], TIMES), "q has 99 values but t has 100"),
    ((TIMES, TIMES, TIMES[:50]), "p has 50 values but t has 100"),
    ((TIMES[:, None], TIMES, TIMES), r"t must be 1-D, got shape \(100, 1\)"),
    ((TIMES, np.zeros((2, 50)), TIMES), "q must be 1-D"),
])
def test_trajectory_rejects_bad_shapes(args, match):
    with pytest.raises(ValueError, match=match):
        plot_trajectory(SHO, *args)


def test_trajectory_rejects_bad_prediction_and_potential(sho_traj):
    with pytest.raises(ValueError, match="p_pred has 3 values"):
        plot_trajectory(SHO, TIMES, *sho_traj, p_pred=np.zeros(3))
    with pytest.raises(ValueError, match=r"sensor values must have shape \(100,\)"):
        plot_trajectory(np.zeros(50), TIMES, *sho_traj)


def test_worst_sample_title_and_data(sho_traj):
    q, p = sho_traj
    fig = plot_worst_sample("traonet", SHO, TIMES, q, p, q * 0.9, p, 1.234e-5)
    assert fig.get_suptitle() == "traonet: worst sample, L_tot = 1.234e-05"
    np.testing.assert_array_equal(fig.axes[1].collections[0].get_offsets()[:, 1], q * 0.9)


# ------------------------------------------------------------ histograms and log bins


@pytest.mark.parametrize("bins", [1, 7, 40])
def test_log_bins_cover_and_are_geometric(bins):
    rng = np.random.default_rng(1)
    a, b = 10 ** rng.uniform(-9, -3, 50), 10 ** rng.uniform(-6, 0, 20)
    edges = log_bins([a, b], bins)
    assert edges.shape == (bins + 1,)
    lo, hi = min(a.min(), b.min()), max(a.max(), b.max())
    assert edges[0] <= lo and edges[-1] >= hi
    ratios = edges[1:] / edges[:-1]
    np.testing.assert_allclose(ratios, (hi / lo) ** (1 / bins), rtol=1e-12)


def test_log_bins_single_value_and_errors():
    edges = log_bins([[1e-4, 1e-4]], 2)
    np.testing.assert_allclose(edges, [10**-4.5, 1e-4, 10**-3.5])
    with pytest.raises(ValueError, match="2 of 3 values are not positive and finite"):
        log_bins([[1.0, 0.0, np.nan]], 5)
    with pytest.raises(ValueError, match="at least one value"):
        log_bins([], 5)
    with pytest.raises(ValueError, match="bins"):
        log_bins([[1.0]], 0)


def test_loss_histograms_counts_medians_and_scale():
    rng = np.random.default_rng(2)
    losses = {f"m{i}": 10 ** rng.normal(-4 - i / 2, 1, 100 + 10 * i) for i in range(10)}
    fig = plot_loss_histograms(losses, bins=25, title="test set")
    (ax,) = fig.axes
    assert ax.get_xscale() == "log" and ax.get_title() == "test set"
    assert len(ax.patches) == len(ax.lines) == 10
    edges = log_bins(losses.values(), 25)
    for hist, median, v in zip(ax.patches, ax.lines, losses.values()):
        values, hist_edges, _ = hist.get_data()
        assert values.sum() == v.size
        np.testing.assert_array_equal(hist_edges, edges)  # shared bins
        assert median.get_xdata()[0] == np.median(v)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert labels[0].startswith("m0 (median")
    assert _render(fig) > 1000


@pytest.mark.parametrize("losses, match", [
    ({"good": [1e-3], "bad": [1e-3, -1.0, 0.0]}, r"losses\['bad'\]: 2 of 3 values"),
    ({"inf": [np.inf, 1.0]}, r"losses\['inf'\]: 1 of 2 values"),
    ({"none": []}, r"losses\['none'\] is empty"),
    ({}, "losses is empty"),
])
def test_loss_histograms_reject_bad_values(losses, match):
    with pytest.raises(ValueError, match=match):
        plot_loss_histograms(losses)


# ---------------------------------------------------------------- work-precision


def _rows():
    rows = [
        {"name": "traonet", "kind": "neural", "family": "traonet", "seconds": 2.4e-3,
         "mean_L_tot": 9e-6},
        {"name": "mambonet", "kind": "neural", "family": "mambonet", "seconds": 8.5e-3,
         "mean_L_tot": 2e-6},
    ]
    for steps, s, loss in ((16, 5e-5, 2.5e-13), (1, 8e-6, 3e-6), (4, 2.2e-5, 6e-11)):
        rows.append({"name": f"rk4 x{steps}", "kind": "classical", "family": "rk4_sensors",
                     "seconds": s, "mean_L_tot": loss})
    for steps, s, loss in ((1, 1e-5, 1e-4), (8, 6e-5, 1e-9)):
        rows.append({"name": f"yoshida x{steps}", "kind": "classical", "family": "yoshida",
                     "seconds": s, "mean_L_tot": loss})
    return rows


def test_work_precision_log_log_one_line_per_family():
    fig = plot_work_precision(_rows(), title="test set")
    (ax,) = fig.axes
    assert ax.get_xscale() == ax.get_yscale() == "log"
    assert [line.get_label() for line in ax.lines] == ["rk4_sensors", "yoshida"]
    rk4 = ax.lines[0]
    np.testing.assert_array_equal(rk4.get_xdata(), [8e-6, 2.2e-5, 5e-5])  # sorted by time
    np.testing.assert_array_equal(rk4.get_ydata(), [3e-6, 6e-11, 2.5e-13])
    assert len(ax.collections) == 2  # one marker per neural model
    np.testing.assert_array_equal(ax.collections[0].get_offsets(), [[2.4e-3, 9e-6]])
    star, diamond = (c.get_paths()[0].vertices for c in ax.collections)
    assert star.shape != diamond.shape or not np.allclose(star, diamond)  # distinct markers
    notes = {t.get_text() for t in ax.texts}
    assert {r["name"] for r in _rows()} <= notes  # every point labelled
    assert _render(fig) > 1000


def test_work_precision_inverse_x():
    fig = plot_work_precision(_rows(), x="trajectories_per_second")
    np.testing.assert_allclose(fig.axes[0].lines[0].get_xdata(), 1 / np.array([8e-6, 2.2e-5, 5e-5]))


@pytest.mark.parametrize("rows, kwargs, match", [
    ([], {}, "rows is empty"),
    ([{"name": "a", "kind": "neural"}], {}, r"rows\[0\] lacks family, seconds, mean_L_tot"),
    ([dict(_rows()[0], kind="hybrid")], {}, "kind must be"),
    ([dict(_rows()[0], seconds=0.0)], {}, "seconds = 0.0 must be positive"),
    (_rows(), {"x": "flops"}, "x must be one of"),
])
def test_work_precision_rejects(rows, kwargs, match):
    with pytest.raises(ValueError, match=match):
        plot_work_precision(rows, **kwargs)


# ---------------------------------------------------------------- physical potentials


def test_physical_potentials_grid():
    names = ["sho", "mff"]
    traj = {n: PHYSICAL_POTENTIALS[n].exact(TIMES) for n in names}
    fig = plot_physical_potentials(PHYSICAL_POTENTIALS, traj)
    assert len(fig.axes) == 4 * len(names) + 1
    # subplots(4, n) are stored row by row: axes[n * row + col]
    for col, name in enumerate(names):
        assert fig.axes[col].get_title() == name
        np.testing.assert_array_equal(fig.axes[len(names) + col].lines[0].get_ydata(), traj[name][0])
        np.testing.assert_array_equal(fig.axes[2 * len(names) + col].lines[0].get_ydata(),
                                      traj[name][1])
    assert fig.axes[-1].get_ylabel() == "t"
    with pytest.raises(ValueError, match="no potential for nope"):
        plot_physical_potentials(PHYSICAL_POTENTIALS, {"nope": traj["sho"]})


def test_work_precision_labels_a_classical_point_by_its_knob():
    rows = [{"name": f"rk4_sensors_{k}", "kind": "classical", "family": "rk4_sensors",
             "seconds": s, "mean_L_tot": loss}
            for k, s, loss in ((1, 1e-5, 1e-4), (16, 4e-5, 1e-9))]
    rows.append({"name": "traonet", "kind": "neural", "family": "traonet", "seconds": 1e-3,
                 "mean_L_tot": 1e-2})
    (ax,) = plot_work_precision(rows).axes
    assert {t.get_text() for t in ax.texts} == {"1", "16", "traonet"}
    assert ax.lines[0].get_label() == "rk4_sensors"
