"""nh-operators: neural operators for Hamilton's equations, with honest classical baselines.

The package is laid out in wings, one per role, each importing only the wings beneath it
(``docs/architecture.rst``): :mod:`~nh_operators.potentials` and
:mod:`~nh_operators.models` at the bottom, then :mod:`~nh_operators.solvers`,
:mod:`~nh_operators.data`, :mod:`~nh_operators.training`,
:mod:`~nh_operators.evaluation`, :mod:`~nh_operators.solving` and
:mod:`~nh_operators.cli`. This module is the curated API: the names a user reaches for
first, re-exported from their wings.

Importing the package selects DeepXDE's PyTorch backend when none is chosen (quietly,
without writing a config file in the home folder).
"""

from ._backend import ensure_pytorch_backend as _ensure_pytorch_backend

_ensure_pytorch_backend()

from ._constants import SENSORS, TIMES, V0  # noqa: E402
from ._version import __version__  # noqa: E402
from .data import OperatorData, generate_dataset, load_dataset  # noqa: E402
from .evaluation import (  # noqa: E402
    CLASSICAL_METHODS,
    ClassicalMethod,
    EvaluationSettings,
    NeuralMethod,
    evaluate_methods,
    extreme_potentials,
)
from .models import MODELS, build_model, count_parameters, predict  # noqa: E402
from .potentials import (  # noqa: E402
    PHYSICAL_POTENTIALS,
    AnalyticPotential,
    BoundedPotential,
    BoundedPotentialSpace,
    ExtendedPotential,
    OutOfDomainWarning,
    check_bounded,
    domain_violations,
    extend_monotone,
    parse_potential,
)
from .solvers import (  # noqa: E402
    METHODS,
    ResolutionWarning,
    integrate,
    integrate_sensors,
    paper_rk4,
    reference_solve,
    solve_classical,
)
from .solving import DEFAULT_TOL, Solution, available_pretrained, pretrained, solve  # noqa: E402
from .training import (  # noqa: E402
    ExpHyperbolicLR,
    HyperbolicLR,
    TrainConfig,
    TrainingDiverged,
    adjusted_infimum_lr,
    load_model,
    train,
)

__all__ = [
    "__version__",
    "V0",
    "SENSORS",
    "TIMES",
    # potentials
    "AnalyticPotential",
    "BoundedPotential",
    "BoundedPotentialSpace",
    "PHYSICAL_POTENTIALS",
    "check_bounded",
    "parse_potential",
    "extend_monotone",
    "ExtendedPotential",
    "OutOfDomainWarning",
    "domain_violations",
    # models
    "MODELS",
    "build_model",
    "count_parameters",
    "predict",
    # solvers
    "METHODS",
    "integrate",
    "integrate_sensors",
    "paper_rk4",
    "reference_solve",
    "solve_classical",
    "ResolutionWarning",
    # data
    "OperatorData",
    "generate_dataset",
    "load_dataset",
    # training
    "ExpHyperbolicLR",
    "HyperbolicLR",
    "adjusted_infimum_lr",
    "TrainConfig",
    "TrainingDiverged",
    "train",
    "load_model",
    # evaluation
    "CLASSICAL_METHODS",
    "ClassicalMethod",
    "NeuralMethod",
    "EvaluationSettings",
    "evaluate_methods",
    "extreme_potentials",
    # solve
    "available_pretrained",
    "pretrained",
    "solve",
    "Solution",
    "DEFAULT_TOL",
]
