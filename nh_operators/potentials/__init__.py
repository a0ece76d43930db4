"""Potentials: what a particle moves in.

The bounded B-spline potential of the paper's generator (exact, batched, compiled), the
generator as a DeepXDE function space, the five physical potentials, potentials typed as
text, the bounded extension of a monotone potential, out-of-distribution families, and
the generator's domain at the sensors. The bottom wing: it imports no other wing.
"""

from .bounded import BoundedPotential, check_bounded
from .coerce import CallablePotential, as_potential
from .domain import GENERATOR_DOMAIN, OutOfDomainWarning, domain_violations
from .expression import FUNCTIONS, parse_expression, parse_potential
from .ood import OOD_FAMILIES, ood_potential, ood_potentials
from .physical import PHYSICAL_POTENTIALS, AnalyticPotential
from .space import BoundedPotentialSpace
from .unbounded import ExtendedPotential, extend_monotone

__all__ = [
    "BoundedPotential",
    "check_bounded",
    "BoundedPotentialSpace",
    "AnalyticPotential",
    "PHYSICAL_POTENTIALS",
    "FUNCTIONS",
    "parse_potential",
    "parse_expression",
    "CallablePotential",
    "as_potential",
    "ExtendedPotential",
    "extend_monotone",
    "OOD_FAMILIES",
    "ood_potential",
    "ood_potentials",
    "GENERATOR_DOMAIN",
    "OutOfDomainWarning",
    "domain_violations",
]
