"""Potentials: what a particle moves in.

The bounded B-spline potential of the paper's generator (exact, batched, compiled), the
generator as a DeepXDE function space, the five physical potentials, potentials typed as
text, the bounded extension of a monotone potential, out-of-distribution families, and
the generator's domain at the sensors. The bottom wing: it imports no other wing.
"""

from .._lazy import attach

__getattr__, __dir__, __all__ = attach(__name__, {
    "bounded": ["BoundedPotential", "check_bounded"],
    "coerce": ["CallablePotential", "as_potential", "check_force"],
    "domain": ["GENERATOR_DOMAIN", "OutOfDomainWarning", "domain_violations", "in_domain",
               "domain_stats", "fit_domain", "wall_forces"],
    "expression": ["FUNCTIONS", "parse_expression", "parse_potential"],
    "ood": ["OOD_FAMILIES", "ood_potential", "ood_potentials"],
    "physical": ["PHYSICAL_POTENTIALS", "AnalyticPotential"],
    "space": ["NORMALIZATIONS", "BoundedPotentialSpace"],
    "unbounded": ["ExtendedPotential", "extend_monotone"],
})
