"""The paper's per-sample loss and its summary statistics (docs/problem.rst), for evaluation.

They are defined beneath every wing, in ``nh_operators._metrics``, because the solvers'
error estimates use them too; this module is where the evaluation wing publishes them.
"""

from .._metrics import energy_error, loss_per_sample, summarize

__all__ = ["loss_per_sample", "summarize", "energy_error"]
