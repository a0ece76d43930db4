"""Write an evaluation report: ``report.json``, ``report.md`` and the figures.

Every file is written atomically (temporary file, then rename), so an interrupted run
never leaves a half-written report.
"""

import io
import json
import math
from pathlib import Path

from ..potentials import PHYSICAL_POTENTIALS
from ..training import write_atomic
from .baselines import physical_reference
from .plots import plot_trajectory, plot_worst_sample
from .summary_plots import plot_loss_histograms, plot_work_precision
from .workprecision import work_precision_markdown, work_precision_rows

__all__ = ["write_report", "write_json", "write_figures", "save_figure", "test_table",
           "physical_table", "timing_table"]

PHYSICAL_TITLES = {"sho": "SHO", "double_well": "Double well", "morse": "Morse",
                   "mff": "MFF", "smff": "SMFF"}


def write_json(path, obj):
    """Atomically write ``obj`` as indented JSON (non-finite floats become null)."""
    write_atomic(path, (json.dumps(_finite(obj), indent=2) + "\n").encode())


def _finite(obj):
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if hasattr(obj, "tolist"):
        return _finite(obj.tolist())
    return obj


def _e(x):
    return "–" if x is None else f"{x:.4e}"


def _ordered(results):
    """Classical methods first (as the paper's RK4 row), then networks, in given order."""
    items = list(results["methods"].items())
    return ([kv for kv in items if kv[1]["kind"] == "classical"]
            + [kv for kv in items if kv[1]["kind"] != "classical"])


def test_table(results):
    """The paper's test-set table: Model | Mean | Std | Median | IQR of L_tot (and n)."""
    lines = ["| Model | Mean L_tot | Std L_tot | Median L_tot | IQR L_tot | n |",
             "|---|---:|---:|---:|---:|---:|"]
    for name, m in _ordered(results):
        s = m["test"]
        lines.append(f"| {name} | {_e(s['mean'])} | {_e(s['std'])} | {_e(s['median'])} | "
                     f"{_e(s['iqr'])} | {s['n']} |")
    return "\n".join(lines)


def physical_table(results):
    """The paper's physical-potentials table: L_tot per potential."""
    names = list(PHYSICAL_TITLES)
    lines = ["| Model | " + " | ".join(PHYSICAL_TITLES[n] for n in names) + " |",
             "|---|" + "---:|" * len(names)]
    for name, m in _ordered(results):
        lines.append(f"| {name} | " + " | ".join(_e(m["physical"].get(n)) for n in names)
                     + " |")
    return "\n".join(lines)


def timing_table(results):
    """The paper's time table at batch 1 (over potentials) plus the batched time."""
    lines = ["| Model | Mean T | Std T | Median T | IQR T | T/traj, batch N | N | device |",
             "|---|---:|---:|---:|---:|---:|---:|---|"]
    for name, m in _ordered(results):
        s = m.get("seconds_per_trajectory") or {}
        st = s.get("batch_1_stats")
        if not st:
            continue
        lines.append(f"| {name} | {_e(st['mean'])} | {_e(st['std'])} | {_e(st['median'])} | "
                     f"{_e(st['iqr'])} | {_e(s.get('batched'))} | {s.get('batched_size')} | "
                     f"{m['device']} |")
    return "\n".join(lines)


def save_figure(fig, path):
    """Atomically write a matplotlib figure in the format its suffix names (default PNG)."""
    buf = io.BytesIO()
    fig.savefig(buf, format=Path(path).suffix.lstrip(".").lower() or "png", dpi=110)
    write_atomic(path, buf.getvalue())


def write_figures(results, arrays, dataset, out_dir):
    """The figures: loss histograms, work precision, worst samples, physical potentials.

    Returns:
        list of the written file names (relative to ``out_dir``).
    """
    out_dir = Path(out_dir)
    written = []
    losses = {n: a["L_tot"] for n, a in arrays.items() if (a["L_tot"] > 0).all()}
    if losses:
        save_figure(plot_loss_histograms(losses, title="test-set L_tot"),
              out_dir / "loss_histograms.png")
        written.append("loss_histograms.png")
    rows = work_precision_rows(results, "batched")
    if rows:
        save_figure(plot_work_precision(rows, title="work precision (large batch)"),
              out_dir / "work_precision.png")
        written.append("work_precision.png")
    t = dataset.t
    refs = {n: physical_reference(n, t) for n in PHYSICAL_POTENTIALS}
    for name, m in results["methods"].items():
        if m["kind"] != "neural":
            continue
        a = arrays[name]
        i = int(a["worst"])
        save_figure(plot_worst_sample(name, dataset.V[i], t, dataset.q[i], dataset.p[i],
                                      a["q_worst"], a["p_worst"], float(a["L_tot"][i])),
              out_dir / f"worst_{name}.png")
        written.append(f"worst_{name}.png")
        for k, pot in enumerate(PHYSICAL_POTENTIALS):
            fig = plot_trajectory(
                PHYSICAL_POTENTIALS[pot], t, *refs[pot], a["physical_q"][k], a["physical_p"][k],
                title=f"{name} on {PHYSICAL_TITLES[pot]}: L_tot = {m['physical'][pot]:.2e}")
            save_figure(fig, out_dir / f"physical_{name}_{pot}.png")
            written.append(f"physical_{name}_{pot}.png")
    return written


def _markdown(results, figures, command, stability_md):
    ts = results["test_set"]
    devices = sorted({m["device"] for m in results["methods"].values()})
    threads = sorted({json.dumps(m["threads"]) for m in results["methods"].values()})
    parts = [
        "# nh-operators evaluation report", "",
        f"Command: `{command}`" if command else "",
        f"Test set: {ts.get('path') or 'in memory'}, {ts['n']} potentials, "
        f"checksum `{ts['checksum']}`.",
        f"Devices: {', '.join(devices)}; threads: {', '.join(threads)}.",
        "Every method sees the potential only at the 100 sensors. L_tot is the paper's "
        "per-sample loss (docs/problem.rst). Methods that solve one trajectory at a time in "
        "Python are scored on the first `n` test potentials only (column n).", "",
        "## Test set", "", test_table(results), "",
        "## Physical potentials", "",
        "L_tot against the exact solution (SHO, MFF) or DOP853 at 1e-13 on the exact "
        "formula.", "", physical_table(results), "",
        "## Time per potential (seconds)", "",
        "Batch 1: each potential timed alone after a warm-up; a potential's time is its "
        "median over repeats, summarised over potentials (the paper's T). Batch N: one "
        "call on N potentials, median over repeats, divided by N.", "",
        timing_table(results), "",
        "## Speed and accuracy", "", work_precision_markdown(results), "",
    ]
    if "work_precision.png" in figures:
        parts += ["![work precision](work_precision.png)", ""]
    if stability_md:
        parts += [stability_md.strip(), ""]
    warned = {n: m["warnings"] for n, m in results["methods"].items() if m.get("warnings")}
    if warned:
        parts += ["## Warnings raised during evaluation", ""]
        parts += [f"- **{n}**: {w}" for n, ws in warned.items() for w in ws]
        parts.append("")
    if figures:
        parts += ["## Figures", ""] + [f"- [{f}]({f})" for f in figures] + [""]
    return "\n".join(p for p in parts if p is not None)


def write_report(results, arrays, dataset, out_dir, *, command=None, stability=None,
                 stability_md=None, figures=True):
    """Write ``report.json``, ``report.md`` and (optionally) the figures to ``out_dir``.

    Args:
        results, arrays: from :func:`~nh_operators.evaluation.evaluate_methods`.
        dataset: the test set they were computed on (for the worst-sample figures).
        out_dir: output folder (created).
        command: the command line, quoted in the report.
        stability: optional stability table, stored under ``"stability"`` in the JSON.
        stability_md: its markdown section.
        figures: also draw the figures.

    Returns:
        Path of ``report.md``.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    names = write_figures(results, arrays, dataset, out_dir) if figures else []
    payload = dict(results)
    if stability is not None:
        payload["stability"] = stability
    write_json(out_dir / "report.json", payload)
    path = out_dir / "report.md"
    write_atomic(path, _markdown(results, names, command, stability_md).encode())
    return path

