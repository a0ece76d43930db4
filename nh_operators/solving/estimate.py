"""A-posteriori error estimates of a predicted trajectory, and their calibration.

A network's prediction (q̂, p̂) on the 100-point grid :data:`TIMES` is checked against
the physics it should obey, using nothing but the potential:

* **energy residual** E = ½ · mean_t (p̂²/2 + V(q̂) − V0)²: the prediction should stay
  on the energy level V0 of a particle released at rest;
* **Picard defect** D = ½ · mean_t (|D_q|² + |D_p|²) with
  D_q(t) = q̂(t) − ∫₀ᵗ p̂ and D_p(t) = p̂(t) + ∫₀ᵗ V′(q̂): the residual of Hamilton's
  equations integrated once (the integrals are exact for the cubic splines through the
  grid values, so no numerical derivative amplifies the network's noise). It sees what
  the energy misses: a prediction that moves along the right energy curve at the wrong
  speed.

Both are in the units of L_tot (mean squared error), and both are taken at the times the
user asked (:func:`estimate_at`: the prediction on the grid is interpolated there by
cubic splines, as :func:`~nh_operators.solve` returns it). Neither bounds the error: the
error of a trajectory is the defect carried through the flow, which can grow. So the
estimate used by :func:`~nh_operators.solve` is ``factor · (E + D)``, with ``factor``
calibrated per network (:func:`~nh_operators.solving.calibrate_pretrained`): a bootstrap
upper bound on the 99.9 % quantile of true L_tot / (E + D) over several families of
inputs it was not trained on, at random asked times. ``calibration.json`` of each shipped
model holds the numbers; ``python benchmarks/pretrained_table.py --calibration`` prints
them.
"""

import functools

import numba
import numpy as np
from scipy.interpolate import CubicSpline

from .._constants import SENSORS, TIMES, V0

__all__ = ["spline_rows", "residuals", "raw_estimate", "estimate_at", "calibrate",
           "CALIBRATION_QUANTILE"]

#: Quantile of L_tot / raw estimate that becomes the calibration factor.
CALIBRATION_QUANTILE = 0.995


def spline_rows(params, q, derivative=0):
    """Evaluate row i's sensor spline at the points q[i] (pairwise, vectorised).

    Args:
        params: (N, 396) per-piece coefficients of
            :func:`~nh_operators.solvers.sensor_spline_params`.
        q: (N, M) points; outside [0, 1] the end pieces are continued.
        derivative: 0 for V, 1 for dV/dq.

    Returns:
        (N, M) array.
    """
    if derivative not in (0, 1):
        raise ValueError(f"derivative must be 0 or 1, got {derivative}")
    q = np.asarray(q, dtype=np.float64)
    params = np.ascontiguousarray(params, dtype=np.float64)
    flat = np.ascontiguousarray(q.reshape(len(params), -1))
    out = np.empty(flat.shape)
    _spline_rows(params, flat, derivative, len(SENSORS) - 1, out)
    return out.reshape(q.shape)


@numba.njit(cache=True, nogil=True)
def _spline_rows(params, q, derivative, pieces, out):
    # the same arithmetic, in the same order, as the vectorised NumPy version it
    # replaced (12× faster on 1,000 rows × 100 points: no (N, M, 4) gather)
    for i in range(q.shape[0]):
        for m in range(q.shape[1]):
            x = pieces * q[i, m]
            j = min(max(int(np.floor(x)), 0), pieces - 1)
            s = x - j
            o = 4 * j
            c0, c1, c2, c3 = params[i, o], params[i, o + 1], params[i, o + 2], params[i, o + 3]
            if derivative == 0:
                out[i, m] = c0 + s * (c1 + s * (c2 + s * c3))
            else:
                out[i, m] = pieces * (c1 + s * (2.0 * c2 + 3.0 * s * c3))


def residuals(q, p, V_rows, dV_rows, t=TIMES):
    """Energy residual and Picard defect of predictions on a time grid.

    Args:
        q, p: (N, M) predictions at the sorted times ``t``, with t[0] = 0.
        V_rows, dV_rows: callables mapping an (N, M) array of positions to V and dV/dq
            of each row's potential.
        t: (M,) increasing times starting at 0 (default :data:`TIMES`).

    Returns:
        (energy, defect): two (N,) arrays, in the units of L_tot.

    Example:
        >>> t = np.linspace(0, 2, 100)
        >>> w = 4.0  # V = 2 - w² q (1 - q) / 2: the exact harmonic trajectory
        >>> q, p = (1 - np.cos(w * t))[None] / 2, (w * np.sin(w * t))[None] / 2
        >>> V = lambda x: 2 - w**2 * x * (1 - x) / 2
        >>> dV = lambda x: -w**2 * (1 - 2 * x) / 2
        >>> e, d = residuals(q, p, V, dV, t)
        >>> bool(e[0] < 1e-28 and d[0] < 1e-12)
        True
    """
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    t = np.asarray(t, dtype=np.float64)
    if t[0] != 0.0 or np.any(np.diff(t) <= 0):
        raise ValueError("t must increase and start at 0")
    energy = 0.5 * np.mean((0.5 * p**2 + V_rows(q) - V0) ** 2, axis=1)
    integrate = _integration_matrix(t.tobytes()).T  # the spline integrals are linear
    int_p = p @ integrate
    int_f = dV_rows(q) @ integrate
    defect = 0.5 * np.mean((q - int_p) ** 2 + (p + int_f) ** 2, axis=1)
    return energy, defect


@functools.lru_cache(maxsize=8)
def _integration_matrix(t_bytes):
    """A with (A y)_i = ∫₀^{t_i} of the not-a-knot cubic spline through (t, y)."""
    t = np.frombuffer(t_bytes, dtype=np.float64)
    return CubicSpline(t, np.eye(t.size), axis=0).antiderivative()(t)


def raw_estimate(q, p, V_rows, dV_rows, t=TIMES):
    """E + D of :func:`residuals`: the uncalibrated estimate of L_tot, shape (N,)."""
    energy, defect = residuals(q, p, V_rows, dV_rows, t)
    return energy + defect


@functools.lru_cache(maxsize=64)
def _at_matrices(t_bytes, at_bytes):
    """(B, A): B y = the not-a-knot spline through (t, y) at the times ``at``, A y = its
    integral from 0 to each of them."""
    t = np.frombuffer(t_bytes, dtype=np.float64)
    at = np.frombuffer(at_bytes, dtype=np.float64)
    spline = CubicSpline(t, np.eye(t.size), axis=0)
    return spline(at), spline.antiderivative()(at)


def estimate_at(q, p, V_rows, dV_rows, at, t=TIMES):
    """A prediction on the grid ``t`` at the asked times ``at``, and its E + D there.

    The prediction between grid times is the cubic spline through the grid values (what
    :func:`~nh_operators.solve` returns). At each asked time t the residual of
    :func:`residuals` (energy and Picard terms) is taken there and, as a floor, its
    largest value on the grid up to t: an error made earlier is carried to t, so a
    residual that happens to vanish at t (one asked time) does not hide it. The
    estimate is the mean over the asked times, so it is of L_tot where the user looks,
    interpolation included.

    Args:
        q, p: (N, K) predictions on the increasing grid ``t`` (t[0] = 0).
        V_rows, dV_rows: callables mapping (N, M) positions to each row's V and dV/dq.
        at: asked times in [t[0], t[-1]], (M,) for every row or (N, M) per row.
        t: (K,) the grid (default :data:`TIMES`).

    Returns:
        (q_at, p_at, raw): (N, M) each, and the (N,) uncalibrated estimate at ``at``
        (on the grid itself, at least :func:`raw_estimate`).

    Example:
        >>> w = 4.0  # the exact harmonic trajectory: E + D vanish at any times
        >>> q, p = (1 - np.cos(w * TIMES))[None] / 2, (w * np.sin(w * TIMES))[None] / 2
        >>> V = lambda x: 2 - w**2 * x * (1 - x) / 2
        >>> dV = lambda x: -w**2 * (1 - 2 * x) / 2
        >>> qa, pa, raw = estimate_at(q, p, V, dV, np.array([0.3, 1.7]))
        >>> bool(abs(qa[0, 0] - (1 - np.cos(1.2)) / 2) < 1e-6 and raw[0] < 1e-10)
        True
    """
    q = np.atleast_2d(np.asarray(q, dtype=np.float64))
    p = np.atleast_2d(np.asarray(p, dtype=np.float64))
    t = np.ascontiguousarray(t, dtype=np.float64)
    at = np.asarray(at, dtype=np.float64)
    if t[0] != 0.0 or np.any(np.diff(t) <= 0):
        raise ValueError("t must increase and start at 0")
    if at.size and (at.min() < t[0] or at.max() > t[-1] + 1e-12):
        raise ValueError(f"the asked times must lie in [{t[0]:g}, {t[-1]:g}]")
    rows = np.broadcast_to(at.reshape(1, -1) if at.ndim <= 1 else at, (len(q), at.shape[-1]))
    shared = at.ndim <= 1
    mats = [_at_matrices(t.tobytes(), np.ascontiguousarray(rows[i]).tobytes())
            for i in range(1 if shared else len(q))]
    force = dV_rows(q)

    def apply(y, k):  # y (N, K) with matrix k of mats, row by row when times differ
        if shared:
            return y @ mats[0][k].T
        return np.stack([y[i] @ mats[i][k].T for i in range(len(y))])

    q_at, p_at = apply(q, 0), apply(p, 0)
    int_p, int_f = apply(p, 1), apply(force, 1)
    here = 0.5 * ((0.5 * p_at**2 + V_rows(q_at) - V0) ** 2 + (q_at - int_p) ** 2
                  + (p_at + int_f) ** 2)
    # the residual on the grid up to each asked time: an error made earlier is carried
    # to t even where the residual at t itself happens to vanish
    integrate = _integration_matrix(t.tobytes()).T
    grid = 0.5 * ((0.5 * p**2 + V_rows(q) - V0) ** 2 + (q - p @ integrate) ** 2
                  + (p + force @ integrate) ** 2)
    running = np.maximum.accumulate(grid, axis=1)
    last = np.clip(np.searchsorted(t, rows, side="right") - 1, 0, t.size - 1)
    behind = np.take_along_axis(running, last, axis=1)
    return q_at, p_at, np.mean(np.maximum(here, behind), axis=1)


def sensor_force(V):
    """(V_rows, dV_rows) of the not-a-knot splines through sensor values V (N, 100)."""
    from ..solvers import sensor_spline_params

    params = sensor_spline_params(np.atleast_2d(V))
    return (lambda q: spline_rows(params, q, 0)), (lambda q: spline_rows(params, q, 1))


def calibrate(method, dataset, *, quantile=CALIBRATION_QUANTILE, batch=1000):
    """Calibrate a network's error estimate on a labelled dataset it has not seen.

    Args:
        method: a :class:`~nh_operators.NeuralMethod` (``method(V, TIMES)``).
        dataset: a :class:`~nh_operators.data.Dataset` on :data:`TIMES`; use potentials
            from neither the training nor the test set (another seed).
        quantile: the factor is this quantile of L_tot / (E + D).
        batch: potentials per pass.

    Returns:
        dict with ``factor``, ``quantile``, ``n``, ``dataset_checksum``,
        ``estimate_quantiles`` (the calibrated estimate at probabilities
        ``probabilities``: how often the network's estimate meets a tolerance) and
        ``L_quantiles`` (its true L_tot there).
    """
    from .._metrics import loss_per_sample

    if not np.allclose(dataset.t, TIMES):
        raise ValueError("the calibration dataset must be on nh_operators.TIMES")
    ratios, raws, losses = [], [], []
    for start in range(0, len(dataset), batch):
        V = np.asarray(dataset.V[start:start + batch])
        q, p = method(V, TIMES)
        raw = raw_estimate(q, p, *sensor_force(V))
        loss = loss_per_sample(q, p, np.asarray(dataset.q[start:start + batch]),
                               np.asarray(dataset.p[start:start + batch]))["L_tot"]
        raws.append(raw)
        losses.append(loss)
        ratios.append(loss / np.maximum(raw, 1e-300))
    raw, loss = np.concatenate(raws), np.concatenate(losses)
    factor = float(np.quantile(np.concatenate(ratios), quantile))
    probabilities = [0.0, 0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 0.99, 1.0]
    return {"factor": factor, "quantile": quantile, "n": int(len(raw)),
            "dataset_checksum": dataset.checksum, "probabilities": probabilities,
            "estimate_quantiles": [float(v) for v in np.quantile(factor * raw, probabilities)],
            "L_quantiles": [float(v) for v in np.quantile(loss, probabilities)]}


def acceptance_rate(calibration, tol):
    """Fraction of the calibration set whose calibrated estimate is ≤ tol
    (interpolated between the stored quantiles in log scale)."""
    est = np.log(np.maximum(calibration["estimate_quantiles"], 1e-300))
    return float(np.interp(np.log(tol), est, calibration["probabilities"], left=0.0,
                           right=1.0))
