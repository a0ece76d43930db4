"""nh-operators: neural operators for Hamilton's equations, with honest classical baselines.

The package is laid out in wings, one per role, each importing only the wings beneath it
(``docs/architecture.rst``): :mod:`~nh_operators.potentials` and
:mod:`~nh_operators.models` at the bottom, then :mod:`~nh_operators.solvers`,
:mod:`~nh_operators.data`, :mod:`~nh_operators.training`,
:mod:`~nh_operators.evaluation`, :mod:`~nh_operators.solving` and
:mod:`~nh_operators.cli`. This module is the curated API: the names a user reaches for
first, re-exported from their wings.

Importing the package is cheap: it selects DeepXDE's PyTorch backend through the
environment (without importing DeepXDE or writing a config file in the home folder), and
each wing loads when a name from it is first used, so a classical solve never loads torch.
"""

from typing import TYPE_CHECKING

from ._backend import select_pytorch_backend

select_pytorch_backend()

from ._constants import SENSORS, TIMES, V0  # noqa: E402
from ._lazy import attach  # noqa: E402
from ._version import __version__  # noqa: E402

__getattr__, __dir__, _names = attach(__name__, {
    "data": ["OperatorData", "generate_dataset", "load_dataset"],
    "evaluation": ["CLASSICAL_METHODS", "ClassicalMethod", "EvaluationSettings",
                   "NeuralMethod", "evaluate_methods", "extreme_potentials"],
    "models": ["MODELS", "build_model", "count_parameters", "from_reference", "predict"],
    "potentials": ["PHYSICAL_POTENTIALS", "AnalyticPotential", "BoundedPotential",
                   "BoundedPotentialSpace", "ExtendedPotential", "OutOfDomainWarning",
                   "check_bounded", "domain_violations", "extend_monotone", "parse_potential"],
    "solvers": ["METHODS", "ResolutionWarning", "integrate", "integrate_sensors", "paper_rk4",
                "reference_solve", "solve_classical"],
    "solving": ["DEFAULT_TOL", "ManySolution", "Solution", "available_pretrained",
                "preload", "pretrained", "solve", "solve_many"],
    "training": ["ExpHyperbolicLR", "HyperbolicLR", "TrainConfig", "TrainingDiverged",
                 "adjusted_infimum_lr", "load_model", "refine", "train"],
})
if TYPE_CHECKING:  # for static checkers only: at run time each name loads lazily
    from .data import OperatorData, generate_dataset, load_dataset
    from .evaluation import (CLASSICAL_METHODS, ClassicalMethod, EvaluationSettings,
                             NeuralMethod, evaluate_methods, extreme_potentials)
    from .models import MODELS, build_model, count_parameters, from_reference, predict
    from .potentials import (PHYSICAL_POTENTIALS, AnalyticPotential, BoundedPotential,
                             BoundedPotentialSpace, ExtendedPotential, OutOfDomainWarning,
                             check_bounded, domain_violations, extend_monotone,
                             parse_potential)
    from .solvers import (METHODS, ResolutionWarning, integrate, integrate_sensors, paper_rk4,
                          reference_solve, solve_classical)
    from .solving import (DEFAULT_TOL, ManySolution, Solution, available_pretrained, preload,
                          pretrained, solve, solve_many)
    from .training import (ExpHyperbolicLR, HyperbolicLR, TrainConfig, TrainingDiverged,
                           adjusted_infimum_lr, load_model, refine, train)

# a plain list, so static checkers see the public names; it must repeat the table above
__all__ = [
    "__version__", "V0", "SENSORS", "TIMES",
    "OperatorData", "generate_dataset", "load_dataset",
    "CLASSICAL_METHODS", "ClassicalMethod", "EvaluationSettings", "NeuralMethod",
    "evaluate_methods", "extreme_potentials",
    "MODELS", "build_model", "count_parameters", "from_reference", "predict",
    "PHYSICAL_POTENTIALS", "AnalyticPotential", "BoundedPotential", "BoundedPotentialSpace",
    "ExtendedPotential", "OutOfDomainWarning", "check_bounded", "domain_violations",
    "extend_monotone", "parse_potential",
    "METHODS", "ResolutionWarning", "integrate", "integrate_sensors", "paper_rk4",
    "reference_solve", "solve_classical",
    "DEFAULT_TOL", "ManySolution", "Solution", "available_pretrained", "preload",
    "pretrained", "solve", "solve_many",
    "ExpHyperbolicLR", "HyperbolicLR", "TrainConfig", "TrainingDiverged",
    "adjusted_infimum_lr", "load_model", "refine", "train",
]
if __all__[4:] != _names:
    raise ImportError("nh_operators.__all__ does not repeat the lazy export table: "
                      f"{sorted(set(__all__[4:]) ^ set(_names))}")
del attach, _names, select_pytorch_backend
