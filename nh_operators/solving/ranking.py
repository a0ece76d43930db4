"""Which method a call may use, and which shipped networks are expected to be cheaper than
the classical solve (:func:`ranked`), the one a single call tries (:func:`choose`).

A network is a candidate when T_net + (1 − P)·T_classical < :data:`SAVING` ·
T_classical, with P the share of its calibration set whose calibrated estimate met the
tolerance and the times those measured at calibration
(:meth:`~nh_operators.solving.calibration.Calibration.expected_seconds`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from .._constants import TIMES
from ..solvers import ORDERS
from .calibration import Calibration
from .catalog import resolve_pretrained, shipped_names
from .kinds import InputKind
from .loader import load

__all__ = [
    "DEFAULT_TOL",
    "SAVING",
    "check_method",
    "choose",
    "clear_cache",
    "method_name",
    "ranked",
]

#: Tolerance of the classical solve when none is given.
DEFAULT_TOL = 1e-8
#: A network is a candidate only when its expected cost is below this share of the
#: classical one: the costs are calibrated medians, and a near tie saves nothing while a
#: rejected estimate pays twice (a network expected 0.5 % cheaper made ``auto`` dearer at
#: tol 1e-3 on Algorithm-1 potentials, ``benchmarks/promise/solve_contract.py``).
SAVING = 0.9
#: The classical methods by name: ``"classical"`` is RK4.
CLASSICAL = {"classical": "rk4", **{m: m for m in ORDERS}}


def method_name(method: Any) -> str:
    """A method name, or the shipped name of an object from
    :func:`~nh_operators.pretrained`.

    Raises:
        ValueError: any other object (its estimate would have no calibration).
    """
    if isinstance(method, str):
        return method
    shipped = getattr(method, "shipped", None)
    if isinstance(shipped, str):
        return shipped
    raise ValueError(f"solve cannot use {method!r} as its method: its error estimate needs "
                     "a calibrated network, so give a shipped model's name or "
                     "nh.pretrained(NAME); call your own network directly (method(V, t) or "
                     "nh.predict(net, V, t))")


def check_method(method: Any, tol: float | None) -> tuple[str, tuple[str, ...]]:
    """(method name, shipped networks), or a clear error for a bad method or tolerance.

    Raises:
        ValueError: ``tol`` not a positive number or None; an unknown method.

    Example:
        >>> check_method("traonet", 1e-6)[0]
        'traonet-alg1'
    """
    method = method_name(method)
    if tol is not None and not (isinstance(tol, (int, float)) and np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a positive number or None, got {tol!r}")
    networks = shipped_names()
    if method != "auto" and method not in CLASSICAL and method not in networks:
        try:
            method = resolve_pretrained(method)  # "traonet" means "traonet-alg1"
        except ValueError:
            pass
    if method != "auto" and method not in CLASSICAL and method not in networks:
        raise ValueError(f"unknown method {method!r}; choose 'auto', 'classical', an "
                         f"integrator {sorted(ORDERS)} or a shipped model {list(networks)}")
    return method, networks


def ranked(tol: float, kind: InputKind, batched: bool = False, states: bool = False,
           horizon: float | None = None) -> tuple[tuple[tuple[str, float, float], ...],
                                                   list[str]]:
    """(candidates, notes): the networks expected to be cheaper than the classical solve,
    as (name, expected seconds, share) cheapest first, and why the others are not.

    Args:
        tol: the tolerance.
        kind: the input kind (which classical cost, which factors).
        batched: weigh the per-row costs inside ``solve_many`` instead of one call's.
        states: the networks that read a starting state, else the others.
        horizon: the latest asked time (:func:`~nh_operators.solving.costs.horizon_key`).
    """
    names = shipped_names()
    calibrations = tuple(load(name).calibration for name in names)
    # Calibration compares by identity (eq=False), so the cache key holds the objects
    # themselves: a replaced calibration is a new key, and no key's object is reused.
    return _ranked_cached(tol, InputKind(kind), batched, states, horizon, names,
                          calibrations)


@functools.lru_cache(maxsize=256)
def _ranked_cached(tol: float, kind: InputKind, batched: bool, states: bool,
                   horizon: float | None, names: tuple[str, ...],
                   calibrations: tuple[Calibration | None, ...]) -> tuple[tuple, list[str]]:
    candidates, notes = [], []
    for name, cal in zip(names, calibrations, strict=True):  # one calibration per name
        if load(name).reads_state != states:
            continue
        if cal is None:
            notes.append(f"{name}: not calibrated")
            continue
        # one call counts on the share it would get from either generator; a batch
        # learns the share on its own rows from a pilot (solve_many)
        expected, share, t_cls = cal.expected_seconds(tol, kind, batched=batched,
                                                      horizon=horizon)
        if expected >= SAVING * t_cls:
            notes.append(f"{name}: meets tol on {share:.0%} of its calibration set, "
                         f"expected {1e6 * expected:.0f} µs against {1e6 * t_cls:.0f} µs "
                         f"(a network must be expected to save {1 - SAVING:.0%})")
        else:
            candidates.append((name, expected, share))
    return tuple(sorted(candidates, key=lambda c: c[1])), notes


def choose(tol: float, values: Callable[[], np.ndarray], t: np.ndarray, kind: InputKind,
           states: bool = False) -> tuple[str | None, str]:
    """The network a single call tries, or None, with the reason in words: the cheapest
    candidate whose domain holds the input.

    One call tries one network: going on to the next after a rejection cost more than it
    saved on ``alg1-test`` at tol 1e-4 (an input one network rejects is often rejected
    again, and a single call has no pilot to tell); ``solve_many``, which learns each
    network's share on its rows from a pilot, goes on to the next. ``values()`` gives
    the sensor values; the costs are weighed first, as they need no evaluation of V.
    ``states``: choose among the networks that read a starting state.
    """
    from ..potentials import domain_violations, in_domain
    from .costs import horizon_key

    candidates, notes = ranked(tol, kind, False, states, horizon_key(t))
    if not candidates:
        what = "reading a starting state " if states else ""
        return None, (f"no network {what}expected to be cheaper ("
                      + ("; ".join(notes) or "none calibrated") + ")")
    if t.min() < 0 or t.max() > TIMES[-1] + 1e-12:
        return None, "times outside [0, 2], where the networks were trained"
    V = values()
    for name, _, share in candidates:
        if in_domain(V, load(name).domain):
            return name, (f"{name} expected cheapest on its domain: its estimate met tol "
                          f"on {share:.0%} of its calibration set")
    first = candidates[0][0]
    return None, (f"outside the domain of every network expected to be cheaper, e.g. "
                  f"{first}'s: {domain_violations(V, load(first).domain)[0]}")


def clear_cache() -> None:
    """Forget the rankings computed so far (they are keyed on the calibrations, so this
    only frees memory)."""
    _ranked_cached.cache_clear()
