"""Evaluation: methods, metrics, timing, reports in the paper's layout.

Every method (network or classical) behind one interface, the work-precision study, the
stability suite at the extremes, and the figures. Imports every wing below it.
"""

from .._metrics import energy_error, loss_per_sample, summarize
from .baselines import CLASSICAL_BASELINES, classical_physical_table, physical_reference
from .methods import (
    CLASSICAL_METHODS,
    EVALUATE_BASELINES,
    ClassicalMethod,
    Method,
    NeuralMethod,
    classical_methods,
    dop853_sensors,
)
from .plots import CMAP, plot_physical_potentials, plot_trajectory, plot_worst_sample
from .report import EvaluationSettings, evaluate_method, evaluate_methods
from .report_files import (
    physical_table,
    save_figure,
    test_table,
    timing_table,
    write_figures,
    write_json,
    write_report,
)
from .stability import (
    ENERGY_BOUNDS,
    EXTREME_CASES,
    case_properties,
    extreme_potentials,
    extreme_reference,
    stability_markdown,
    stability_table,
)
from .study import benchmark_report, evaluate_report, load_methods
from .summary_plots import log_bins, plot_loss_histograms, plot_work_precision
from .timing import (
    busy_machine_warning,
    cpu_name,
    device_info,
    seconds_per_trajectory,
    time_call,
)
from .workprecision import (
    faster_interval,
    faster_statements,
    work_precision_markdown,
    work_precision_rows,
)

__all__ = [
    "energy_error",
    "loss_per_sample",
    "summarize",
    "Method",
    "ClassicalMethod",
    "NeuralMethod",
    "CLASSICAL_METHODS",
    "EVALUATE_BASELINES",
    "classical_methods",
    "dop853_sensors",
    "CLASSICAL_BASELINES",
    "physical_reference",
    "classical_physical_table",
    "cpu_name",
    "device_info",
    "busy_machine_warning",
    "time_call",
    "seconds_per_trajectory",
    "work_precision_rows",
    "faster_interval",
    "faster_statements",
    "work_precision_markdown",
    "EXTREME_CASES",
    "ENERGY_BOUNDS",
    "extreme_potentials",
    "extreme_reference",
    "case_properties",
    "stability_table",
    "stability_markdown",
    "CMAP",
    "plot_trajectory",
    "plot_worst_sample",
    "plot_physical_potentials",
    "log_bins",
    "plot_loss_histograms",
    "plot_work_precision",
    "write_report",
    "write_json",
    "write_figures",
    "save_figure",
    "test_table",
    "physical_table",
    "timing_table",
    "EvaluationSettings",
    "evaluate_methods",
    "evaluate_method",
    "load_methods",
    "evaluate_report",
    "benchmark_report",
]
