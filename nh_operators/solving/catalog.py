"""The shipped weights on disk: where they are, which models there are, and the domain
of each (torch-free).

A shipped model is a folder ``weights/NAME``. Its name says the data it was trained on:
``MODEL-paper`` on ``paper-standard`` (the distribution of the paper's tables) and
``MODEL-alg1`` on ``alg1-standard`` (Algorithm 1 as printed); ``phaseonet-*`` on the
``-extended`` presets (100,000 potentials) of the same distributions;
``phaseonet-paper-states`` and ``phaseonet-alg1-states`` on the ``-states-extended``
presets, from starting states stratified by energy (they read (q0, p0) after the
sensors: :func:`reads_state`). A bare model name
(``"traonet"``) means its ``-alg1`` weights, as earlier releases shipped.
"""

import functools
import json
from pathlib import Path

from ..potentials import GENERATOR_DOMAIN
from ..training.files import CHECKPOINT

__all__ = [
    "CALIBRATION",
    "DOMAIN",
    "WEIGHTS",
    "available_pretrained",
    "network_domain",
    "reads_state",
    "refresh",
    "resolve_pretrained",
    "shipped_names",
]

#: Folder of the shipped weights, one sub-folder per model.
WEIGHTS = Path(__file__).parent / "weights"
#: File of a shipped model's calibration, next to its weights.
CALIBRATION = "calibration.json"
#: File of a shipped model's domain (:func:`~nh_operators.potentials.fit_domain` of its
#: training rows), next to its weights.
DOMAIN = "domain.json"
#: What a bare model name stands for.
DEFAULT_SUFFIX = "-alg1"


def available_pretrained():
    """Names of the shipped models, sorted.

    Example:
        >>> "traonet-paper" in available_pretrained()
        True
    """
    return list(shipped_names())


@functools.lru_cache(maxsize=1)
def shipped_names():
    """The shipped models' names, sorted, as a tuple; read once until :func:`refresh`
    (which :func:`~nh_operators.export_pretrained` calls)."""
    if not WEIGHTS.is_dir():
        return ()
    return tuple(sorted(p.name for p in WEIGHTS.iterdir() if (p / CHECKPOINT).is_file()))


def refresh():
    """Read the shipped folders again (names, domains, state flags): after weights were
    exported or a domain refitted in this process."""
    for cached in (shipped_names, network_domain, reads_state):
        cached.cache_clear()


def resolve_pretrained(name):
    """The shipped folder a name means: itself, or for a bare model name its ``-alg1``
    weights; case does not matter.

    Raises:
        ValueError: for a name that is not shipped (listing the available ones).

    Example:
        >>> resolve_pretrained("TraONet"), resolve_pretrained("traonet-paper")
        ('traonet-alg1', 'traonet-paper')
    """
    names = available_pretrained()
    key = name.lower() if isinstance(name, str) else name
    if key in names:
        return key
    if isinstance(key, str) and key + DEFAULT_SUFFIX in names:
        return key + DEFAULT_SUFFIX
    raise ValueError(f"no pretrained model {name!r}; available: {names or 'none'}")


@functools.cache
def network_domain(name):
    """The inputs shipped model ``name`` was trained on, as bounds at the sensors: its
    ``domain.json``, else :data:`~nh_operators.potentials.GENERATOR_DOMAIN`.

    Example:
        >>> network_domain("traonet-paper")["source"]
        'paper-standard (training rows)'
    """
    path = WEIGHTS / name / DOMAIN
    if not path.is_file():
        return GENERATOR_DOMAIN
    domain = json.loads(path.read_text())
    domain["V_range"] = tuple(domain["V_range"])
    return domain


@functools.cache
def reads_state(name):
    """Whether shipped model ``name`` takes a starting state (q0, p0) after the sensors
    (its config's ``arch`` has ``initial_state``); read from ``config.json``, torch-free.

    Example:
        >>> reads_state("traonet-paper")
        False
    """
    path = WEIGHTS / name / "config.json"
    if not path.is_file():
        return False
    return bool(json.loads(path.read_text()).get("arch", {}).get("initial_state", False))
