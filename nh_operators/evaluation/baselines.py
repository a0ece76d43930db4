"""Losses and the classical baselines on the physical potentials (DESIGN §2)."""

import functools
import time
import warnings

import numpy as np

from ._constants import SENSORS, TIMES, V0
from .methods import CLASSICAL_METHODS
from .physical import PHYSICAL_POTENTIALS
from .resolution import ResolutionWarning
from .solvers import integrate, reference_solve

__all__ = ["CLASSICAL_BASELINES", "loss_per_sample", "summarize", "energy_error",
           "physical_reference", "classical_physical_table"]


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


def summarize(values):
    """Mean, std, median and IQR of per-sample values (the paper's statistics).

    Args:
        values: array of shape (N,), e.g. per-sample L_tot.

    Returns:
        dict with ``mean``, ``std`` (population), ``median``, ``iqr`` (75th minus 25th
        percentile) as floats, and ``n``.

    Raises:
        ValueError: if ``values`` is empty or not finite.

    Example:
        >>> summarize([1.0, 2.0, 3.0, 4.0])["iqr"]
        1.5
    """
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    if v.size == 0:
        raise ValueError("summarize needs at least one value")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{np.count_nonzero(~np.isfinite(v))} of {v.size} values are "
                         "not finite")
    q25, q50, q75 = np.percentile(v, [25, 50, 75])
    return {"mean": float(v.mean()), "std": float(v.std()), "median": float(q50),
            "iqr": float(q75 - q25), "n": int(v.size)}


def energy_error(q, p, potential, energy=V0):
    """Largest energy error of trajectories: max over times of |p²/2 + V(q) − E|.

    Args:
        q, p: trajectories, shape (M,) or (N, M).
        potential: an object with ``V(q)`` (vectorised): one potential, or a batched
            :class:`~nh_operators.BoundedPotential` of N (row i uses potential i).
        energy: the conserved energy E (default V0 = 2: released at rest at q = 0).

    Returns:
        float for 1-D input, else an array (N,).

    Example:
        >>> import nh_operators as nh
        >>> q, p = nh.PHYSICAL_POTENTIALS["sho"].exact(nh.TIMES)
        >>> energy_error(q, p, nh.PHYSICAL_POTENTIALS["sho"]) < 1e-14
        True
    """
    q, p = np.asarray(q, dtype=np.float64), np.asarray(p, dtype=np.float64)
    if q.shape != p.shape or q.ndim not in (1, 2):
        raise ValueError(f"q and p must share a shape (M,) or (N, M), got {q.shape} "
                         f"and {p.shape}")
    if getattr(potential, "batched", False):
        if q.ndim != 2 or len(potential) != q.shape[0]:
            raise ValueError(f"a batch of {len(potential)} potentials needs q of shape "
                             f"({len(potential)}, M), got {q.shape}")
        V = np.stack([potential[i].V(q[i]) for i in range(q.shape[0])])
    else:
        V = potential.V(q)
    err = np.max(np.abs(0.5 * p**2 + V - energy), axis=-1)
    return float(err) if q.ndim == 1 else err


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
#: :data:`~nh_operators.methods.CLASSICAL_METHODS`: callables (V, t) -> (q, p).
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
