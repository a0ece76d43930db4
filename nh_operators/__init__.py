"""nh-operators: neural operators for Hamilton's equations, with honest classical baselines.

Importing the package selects DeepXDE's PyTorch backend when none is chosen (quietly,
without writing a config file in the home folder).
"""

from ._backend import ensure_pytorch_backend as _ensure_pytorch_backend

_ensure_pytorch_backend()

from ._constants import SENSORS, TIMES, V0  # noqa: E402
from ._version import __version__  # noqa: E402
from .physical import PHYSICAL_POTENTIALS, AnalyticPotential  # noqa: E402
from .potentials import BoundedPotential, check_bounded  # noqa: E402
from .solvers import (  # noqa: E402
    METHODS,
    integrate,
    integrate_sensors,
    paper_rk4,
    reference_solve,
)
from .space import BoundedPotentialSpace  # noqa: E402
from .checkpoint import load_model  # noqa: E402
from .inference import predict  # noqa: E402
from .models import MODELS, build_model, count_parameters  # noqa: E402
from .operator_data import OperatorData  # noqa: E402
from .schedulers import ExpHyperbolicLR, HyperbolicLR, adjusted_infimum_lr  # noqa: E402
from .unbounded import ExtendedPotential, extend_monotone  # noqa: E402
from .train import TrainConfig, TrainingDiverged, train  # noqa: E402
from .resolution import ResolutionWarning  # noqa: E402
from .methods import CLASSICAL_METHODS, ClassicalMethod, NeuralMethod  # noqa: E402
from .report import EvaluationSettings, evaluate_methods  # noqa: E402
from .stability import OutOfDomainWarning, domain_violations, extreme_potentials  # noqa: E402
from .pretrained import available_pretrained, pretrained  # noqa: E402
from .classical_solve import solve_classical  # noqa: E402
from .expression import parse_potential  # noqa: E402
from .auto_solve import DEFAULT_TOL, Solution, solve  # noqa: E402

__all__ = [
    "__version__",
    "V0",
    "SENSORS",
    "TIMES",
    "AnalyticPotential",
    "BoundedPotential",
    "BoundedPotentialSpace",
    "METHODS",
    "PHYSICAL_POTENTIALS",
    "check_bounded",
    "integrate",
    "integrate_sensors",
    "paper_rk4",
    "reference_solve",
    "MODELS",
    "build_model",
    "count_parameters",
    "OperatorData",
    "ExpHyperbolicLR",
    "adjusted_infimum_lr",
    "extend_monotone",
    "ExtendedPotential",
    "HyperbolicLR",
    "TrainConfig",
    "TrainingDiverged",
    "train",
    "load_model",
    "predict",
    "ResolutionWarning",
    "OutOfDomainWarning",
    "domain_violations",
    "extreme_potentials",
    "CLASSICAL_METHODS",
    "ClassicalMethod",
    "NeuralMethod",
    "EvaluationSettings",
    "evaluate_methods",
    "available_pretrained",
    "pretrained",
    "solve_classical",
    "parse_potential",
    "solve",
    "Solution",
    "DEFAULT_TOL",
]
