"""Evaluation: methods, metrics, timing, reports in the paper's layout.

Every method (network or classical) behind one interface, the work-precision study, the
stability suite at the extremes, and the figures. Imports every wing below it.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "metrics": ["energy_error", "loss_per_sample", "summarize"],
    "flow_structure": ["area_defect", "flow_jacobian", "network_flow", "network_jacobian",
                       "project_energy",
                       "reversibility_error", "symplectic_defect"],
    "baselines": ["CLASSICAL_BASELINES", "classical_physical_table", "physical_reference"],
    "methods": ["CLASSICAL_METHODS", "EVALUATE_BASELINES", "ClassicalMethod", "Method",
                "NeuralMethod", "classical_methods", "dop853_sensors"],
    "plots": ["CMAP", "plot_physical_potentials", "plot_trajectory", "plot_worst_sample"],
    "report": ["EvaluationSettings", "evaluate_method", "evaluate_methods"],
    "report_files": ["physical_table", "save_figure", "test_table", "timing_table",
                     "write_figures", "write_json", "write_report"],
    "stability": ["ENERGY_BOUNDS", "EXTREME_CASES", "case_properties", "extreme_potentials",
                  "extreme_reference", "stability_markdown", "stability_table"],
    "study": ["benchmark_report", "evaluate_report", "load_methods"],
    "summary_plots": ["log_bins", "plot_loss_histograms", "plot_work_precision"],
    "timing": ["busy_machine_warning", "cpu_name", "device_info", "seconds_per_trajectory",
               "time_call"],
    "workprecision": ["faster_interval", "faster_statements", "work_precision_markdown",
                      "work_precision_rows"],
})
