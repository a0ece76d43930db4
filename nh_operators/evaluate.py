"""Losses and the classical baselines on the physical potentials (DESIGN §2)."""

import time

import numpy as np

from ._constants import SENSORS, TIMES
from .physical import PHYSICAL_POTENTIALS
from .solvers import integrate, integrate_sensors, paper_rk4, reference_solve

__all__ = ["CLASSICAL_BASELINES", "loss_per_sample", "physical_reference", "classical_physical_table"]


def loss_per_sample(q, p, q_ref, p_ref):
    """The paper's per-sample losses.

    Args:
        q, p: predictions, shape (M,) or (N, M).
        q_ref, p_ref: references of the same shape.

    Returns:
        dict of arrays ``L_q``, ``L_p``, ``L_tot`` (scalars for 1-D input, else (N,)),
        L_q = mean over times of (q - q_ref)², L_tot = (L_q + L_p) / 2.

    Example:
        >>> loss_per_sample(np.ones(4), np.zeros(4), np.zeros(4), np.zeros(4))["L_tot"]
        np.float64(0.5)
    """
    lq = np.mean((np.asarray(q) - q_ref) ** 2, axis=-1)
    lp = np.mean((np.asarray(p) - p_ref) ** 2, axis=-1)
    return {"L_q": lq, "L_p": lp, "L_tot": 0.5 * (lq + lp)}


def physical_reference(name, t=TIMES):
    """Reference (q, p) of a physical potential: exact if known, else DOP853 at 1e-13."""
    pot = PHYSICAL_POTENTIALS[name]
    exact = pot.exact(t)
    return exact if exact is not None else reference_solve(pot, t)


#: Classical baselines on sensor values: name -> callable(V (N, 100), t) -> (q, p).
CLASSICAL_BASELINES = {
    "rk4_sensors_1": lambda V, t: integrate_sensors(V, t, "rk4", 1),
    "rk4_sensors_4": lambda V, t: integrate_sensors(V, t, "rk4", 4),
    "rk4_sensors_16": lambda V, t: integrate_sensors(V, t, "rk4", 16),
    "yoshida4_sensors_4": lambda V, t: integrate_sensors(V, t, "yoshida4", 4),
    "yoshida8_sensors_4": lambda V, t: integrate_sensors(V, t, "yoshida8", 4),
    "paper_rk4": lambda V, t: paper_rk4(V, t),
}


def classical_physical_table(t=TIMES, baselines=None, repeats=3):
    """L_tot and time of classical baselines on the five physical potentials.

    Each baseline sees only the 100 sensor values, like a neural operator; one more row,
    ``rk4_exact_16``, integrates the exact formula of V with 16 RK4 steps per interval.

    Args:
        t: query times.
        baselines: dict name -> callable(V, t) (default :data:`CLASSICAL_BASELINES`).
        repeats: timing repeats (the median is reported).

    Returns:
        dict ``{method: {potential: {"L_tot": float, "seconds": float}}}``.
    """
    baselines = dict(CLASSICAL_BASELINES if baselines is None else baselines)
    refs = {name: physical_reference(name, t) for name in PHYSICAL_POTENTIALS}
    table = {}
    for method, run in list(baselines.items()) + [("rk4_exact_16", None)]:
        row = {}
        for name, pot in PHYSICAL_POTENTIALS.items():
            times = []
            for _ in range(repeats):
                start = time.perf_counter()
                if run is None:
                    q, p = integrate(pot, t, "rk4", 16)
                else:
                    q, p = run(pot.V(SENSORS), t)
                times.append(time.perf_counter() - start)
            loss = loss_per_sample(q, p, *refs[name])["L_tot"]
            row[name] = {"L_tot": float(loss), "seconds": float(np.median(times))}
        table[method] = row
    return table
