"""The two jobs behind ``nh-operators evaluate`` and ``nh-operators benchmark``.

* :func:`evaluate_report` — trained runs next to the main classical baselines: test
  set, physical potentials, timings, the stability section, figures and ``report.json``.
* :func:`benchmark_report` — the speed/accuracy study: every classical method (RK4 on
  sensors at 1–16 substeps, Verlet, Yoshida 4/6/8, DOP853 at four tolerances, the
  paper-replica RK4) and any runs, as a work-precision table, figure and statements.

Both cache per-method results in ``OUT/cache`` and resume after an interruption.
"""

import shlex
import sys
from pathlib import Path

from ..data import load_dataset
from ..training import write_atomic
from .methods import EVALUATE_BASELINES, NeuralMethod, classical_methods
from .report import evaluate_methods
from .report_files import save_figure, write_json, write_report
from .summary_plots import plot_work_precision
from .workprecision import (
    REGIMES,
    faster_statements,
    work_precision_markdown,
    work_precision_rows,
)

__all__ = ["load_methods", "evaluate_report", "benchmark_report"]


def load_methods(runs=(), classical=EVALUATE_BASELINES, *, device="cpu", batch_size=1000):
    """Networks from run directories plus classical baselines, keyed by unique names.

    Args:
        runs: run directories written by ``nh-operators train``.
        classical: names in :data:`~nh_operators.evaluation.CLASSICAL_METHODS` (None: all).
        device: device for the networks.
        batch_size: potentials per forward pass.

    Returns:
        dict name -> method. Two runs of one model are told apart by their folder name.

    Raises:
        FileNotFoundError: for a missing run directory.
        ValueError: for an unknown classical method or two runs with the same name.
    """
    methods = {}
    for run in runs:
        m = NeuralMethod.from_run(run, device=device, batch_size=batch_size)
        if m.name in methods:
            m.name = f"{m.name}[{Path(run).resolve().name}]"
            m.family = m.name
        if m.name in methods:
            raise ValueError(f"two runs are both called {m.name!r}; rename a folder")
        methods[m.name] = m
    overlap = set(methods) & set(classical or ())
    if overlap:
        raise ValueError(f"run names clash with classical methods: {sorted(overlap)}")
    methods.update(classical_methods(classical))
    return methods


def _evaluate(test, out, runs, classical, device, settings, fresh, progress):
    """Load the test set and the methods, and evaluate them with the cache in OUT/cache."""
    dataset = load_dataset(test)
    dataset.attrs["path"] = str(test)
    methods = load_methods(runs, classical, device=device)
    results, arrays = evaluate_methods(methods, dataset, settings, cache_dir=Path(out) / "cache",
                                       fresh=fresh, progress=progress)
    return dataset, methods, results, arrays


def _command(argv):
    return "nh-operators " + " ".join(shlex.quote(a) for a in (argv or sys.argv[1:]))


def evaluate_report(runs, test, out, *, classical=EVALUATE_BASELINES, device="cpu",
                    settings=None, stability=True, figures=True, fresh=False, progress=True,
                    argv=None):
    """Evaluate runs and baselines on a test file and write the report folder.

    Args:
        runs: run directories.
        test: path of the labelled test set (``nh-operators generate --preset test``).
        out: report folder; gets ``report.md``, ``report.json``, figures and ``cache/``.
        classical: classical baselines to include.
        device: device for the networks.
        settings: :class:`~nh_operators.evaluation.EvaluationSettings`.
        stability: add the stability-at-the-extremes section.
        figures: draw the figures.
        fresh: recompute every method, ignoring ``out/cache``.
        progress: progress bar.
        argv: the command line to quote in the report.

    Returns:
        (path of report.md, results dict).
    """
    dataset, methods, results, arrays = _evaluate(test, out, runs, classical, device,
                                                  settings, fresh, progress)
    table = md = None
    if stability:
        from .stability import stability_markdown, stability_table

        table = stability_table(methods)
        md = stability_markdown(table)
    path = write_report(results, arrays, dataset, out, command=_command(argv),
                        stability=table, stability_md=md, figures=figures)
    return path, results


def benchmark_report(test, out, runs=(), *, classical=None, device="cpu", settings=None,
                     figures=True, fresh=False, progress=True, argv=None):
    """The speed/accuracy study on a test file: work-precision table, figure, statements.

    Writes ``work_precision.md``, ``work_precision.json`` (the ``report.json`` shape)
    and ``work_precision.png`` to ``out``.

    Args:
        test: labelled test set path.
        out: output folder.
        runs: run directories of trained networks (optional).
        classical: classical methods (default: all of them).
        device, settings, figures, fresh, progress, argv: as :func:`evaluate_report`.

    Returns:
        (path of work_precision.md, results dict).
    """
    out = Path(out)
    dataset, _, results, _ = _evaluate(test, out, runs, classical, device, settings, fresh,
                                       progress)
    out.mkdir(parents=True, exist_ok=True)
    write_json(out / "work_precision.json", results)
    text = ["# Speed and accuracy (work precision)", "",
            f"Command: `{_command(argv)}`", "",
            f"Test set: {test}, {len(dataset)} potentials, checksum `{dataset.checksum}`.",
            "x: seconds per trajectory; y: test-set mean L_tot. A network is faster than "
            "every classical method at target ε when its mean L_tot ≤ ε and no classical "
            "method meeting ε is as fast.", "", work_precision_markdown(results), ""]
    if figures and work_precision_rows(results, "batched"):
        for regime in ("batched", "batch_1"):
            rows = work_precision_rows(results, regime)
            name = "work_precision.png" if regime == "batched" else "work_precision_batch1.png"
            save_figure(plot_work_precision(rows, title=f"work precision ({regime})"),
                        out / name)
            text += [f"![{regime}]({name})", ""]
    path = out / "work_precision.md"
    write_atomic(path, "\n".join(text).encode())
    return path, results


def statements(results):
    """All faster-than-classical sentences of a result, both regimes."""
    return [s for regime in REGIMES
            for s in faster_statements(work_precision_rows(results, regime), regime)]
