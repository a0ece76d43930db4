"""The classical baselines on the five physical potentials, and their references."""

import functools
import time
import warnings

import numpy as np

from .._constants import SENSORS, TIMES
from .._metrics import loss_per_sample
from ..potentials import PHYSICAL_POTENTIALS
from ..solvers import ResolutionWarning, integrate, reference_solve
from .methods import CLASSICAL_METHODS

__all__ = ["CLASSICAL_BASELINES", "physical_reference", "classical_physical_table"]


def physical_reference(name, t=TIMES):
    """Reference (q, p) of a physical potential: exact if known, else DOP853 at 1e-13.

    Solves are remembered per (name, times), so evaluating many methods costs one each;
    the arrays returned are read-only.
    """
    t = np.asarray(t, dtype=np.float64)
    return _reference(name, t.tobytes(), t.shape)


@functools.lru_cache(maxsize=64)
def _reference(name, t_bytes, shape):
    t = np.frombuffer(t_bytes).reshape(shape)
    pot = PHYSICAL_POTENTIALS[name]
    exact = pot.exact(t)
    q, p = exact if exact is not None else reference_solve(pot, t)
    for a in (q, p):
        a.flags.writeable = False
    return q, p


#: Classical baselines of the physical-potential table (``nh-operators demo``), from
#: :data:`~nh_operators.evaluation.CLASSICAL_METHODS`: callables (V, t) -> (q, p).
CLASSICAL_BASELINES = {name: CLASSICAL_METHODS[name] for name in (
    "rk4_sensors_1", "rk4_sensors_4", "rk4_sensors_16", "yoshida4_sensors_4",
    "yoshida8_sensors_4", "paper_rk4")}


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
                if run is None:  # MFF's kink warns: this row is there to show its cost
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore", ResolutionWarning)
                        q, p = integrate(pot, t, "rk4", 16)
                else:
                    q, p = run(pot.V(SENSORS), t)
                times.append(time.perf_counter() - start)
            loss = loss_per_sample(q, p, *refs[name])["L_tot"]
            row[name] = {"L_tot": float(np.squeeze(loss)), "seconds": float(np.median(times))}
        table[method] = row
    return table
