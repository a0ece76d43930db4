"""The paper's per-sample losses and summary statistics (docs/problem.rst), shared by every wing.

The solvers estimate their errors in L_tot, training reports it and the evaluation
summarises it; the public names are re-exported by :mod:`nh_operators.evaluation`.
"""

import numpy as np

from ._constants import V0

__all__ = ["loss_per_sample", "summarize", "energy_error"]


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
    """Largest energy error of trajectories: max over times of ``|p²/2 + V(q) − E|``.

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
