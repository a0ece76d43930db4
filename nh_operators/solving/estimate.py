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

Both are in the units of L_tot (mean squared error). Neither is the error: the error
of a trajectory is the defect carried through the flow, and a phase drift grows along
the trajectory while the defect sees it only locally. So the estimate that
:func:`~nh_operators.solve` uses (:func:`estimate_at`) carries the signed defect through
the flow linearised about the prediction (:func:`propagated_error`), at the times the
user asked: to first order in the error, that is the error itself. Its calibrated form
is ``factor · raw``, with ``factor`` calibrated per network
(:func:`~nh_operators.solving.calibrate_pretrained`): a bootstrap upper bound on the
99.9 % quantile of true L_tot / raw over several families of inputs it was not trained
on, at random asked times. ``calibration.json`` of each shipped model holds the numbers;
``python benchmarks/paper/pretrained_table.py --calibration`` prints them.
"""

import functools

import numba
import numpy as np

from .._constants import SENSORS, TIMES, V0

__all__ = [
    "estimate_at",
    "exact_force",
    "propagated_error",
    "raw_estimate",
    "residuals",
    "sensor_force",
    "spline_rows",
]

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
    from scipy.interpolate import CubicSpline  # a slow import: only for a network's estimate

    t = np.frombuffer(t_bytes, dtype=np.float64)
    return CubicSpline(t, np.eye(t.size), axis=0).antiderivative()(t)


def raw_estimate(q, p, V_rows, dV_rows, t=TIMES):
    """The uncalibrated estimate of L_tot on the grid itself (:func:`estimate_at` at
    ``t``), shape (N,)."""
    return estimate_at(q, p, V_rows, dV_rows, t, t)[2]


@functools.lru_cache(maxsize=8)
def _basis(t_bytes):
    """Piecewise coefficients (scipy's PPoly layout, highest power first) of the
    not-a-knot splines through the unit vectors on the grid, and of their integrals."""
    from scipy.interpolate import CubicSpline  # a slow import: only for a network's estimate

    t = np.frombuffer(t_bytes, dtype=np.float64)
    spline = CubicSpline(t, np.eye(t.size), axis=0)
    return t, spline.c, spline.antiderivative().c


@functools.lru_cache(maxsize=64)
def _at_matrices(t_bytes, at_bytes):
    """(B, A): B y = the not-a-knot spline through (t, y) at the times ``at``, A y = its
    integral from 0 to each of them (Horner on the cached basis: a new set of times
    costs tens of µs, not a spline construction)."""
    t, c, c_int = _basis(t_bytes)
    at = np.frombuffer(at_bytes, dtype=np.float64)
    piece = np.clip(np.searchsorted(t, at, side="right") - 1, 0, t.size - 2)
    dx = (at - t[piece])[:, None]
    values, integrals = c[0, piece], c_int[0, piece]
    for k in range(1, c.shape[0]):
        values = values * dx + c[k, piece]
    for k in range(1, c_int.shape[0]):
        integrals = integrals * dx + c_int[k, piece]
    return values, integrals


def estimate_at(q, p, V_rows, dV_rows, at, t=TIMES, *, q0: float | np.ndarray = 0.0,
                p0: float | np.ndarray = 0.0):
    """A prediction on the grid ``t`` at the asked times ``at``, and its estimated L_tot.

    The prediction between grid times is the cubic spline through the grid values (what
    :func:`~nh_operators.solve` returns). The error e = (q̂ − q, p̂ − p) of a prediction
    obeys, to first order in e, the integral equation e(t) = d(t) + ∫₀ᵗ J(s) e(s) ds,
    with d = (D_q, D_p) the signed Picard defect of :func:`residuals` and
    J = [[0, 1], [−V″(q̂), 0]] the flow's Jacobian along the prediction. So e = d + w,
    where w′ = J (w + d), w(0) = 0, is the defect carried through the flow linearised
    about the prediction (:func:`propagated_error`): a phase drift, which the defect
    sees only locally, grows in w as it does in the true error.

    At each asked time the estimate is the larger of ½|e|² there and, as a floor, its
    largest value on the grid up to that time (an error made earlier is carried to t,
    so an error curve that happens to cross zero at the one asked time does not hide
    it); the estimate is the mean over the asked times, so it is of L_tot where the
    user looks, interpolation included.

    Args:
        q, p: (N, K) predictions on the increasing grid ``t`` (t[0] = 0).
        V_rows, dV_rows: callables mapping (N, M) positions to each row's V and dV/dq
            (V″ over each grid interval is the secant of dV/dq, :func:`_curvature`).
        at: asked times in [t[0], t[-1]], (M,) for every row or (N, M) per row.
        t: (K,) the grid (default :data:`TIMES`).
        q0, p0: the starting state, scalars or (N,) (default (0, 0)): the defect is
            D_q = q̂ − q0 − ∫ p̂, D_p = p̂ − p0 + ∫ V′(q̂).

    Returns:
        (q_at, p_at, raw): (N, M) each, and the (N,) uncalibrated estimate at ``at``.

    Example:
        >>> w = 4.0  # the exact harmonic trajectory: no error to carry
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
    on_grid = shared and np.array_equal(at.reshape(-1), t)
    mats = [] if on_grid else [_at_matrices(t.tobytes(), np.ascontiguousarray(rows[i]).tobytes())
                               for i in range(1 if shared else len(q))]
    force = dV_rows(q)

    def apply(y, k):  # y (N, K) with matrix k of mats, row by row when times differ
        if shared:
            return y @ mats[0][k].T
        return np.stack([y[i] @ mats[i][k].T for i in range(len(y))])

    integrate = _integration_matrix(t.tobytes()).T
    q0 = np.reshape(np.asarray(q0, dtype=np.float64), (-1, 1))
    p0 = np.reshape(np.asarray(p0, dtype=np.float64), (-1, 1))
    d_q, d_p = q - q0 - p @ integrate, p - p0 + force @ integrate
    w_q, w_p = propagated_error(d_q, d_p, _curvature(dV_rows, q, force), t)
    running = np.maximum.accumulate(0.5 * ((d_q + w_q) ** 2 + (d_p + w_p) ** 2), axis=1)
    if on_grid:  # asked at the grid itself: the error there is d + w, below its running max
        return q.copy(), p.copy(), np.mean(running, axis=1)
    q_at, p_at = apply(q, 0), apply(p, 0)
    here = 0.5 * ((q_at - q0 - apply(p, 1) + apply(w_q, 0)) ** 2
                  + (p_at - p0 + apply(force, 1) + apply(w_p, 0)) ** 2)
    last = np.clip(np.searchsorted(t, rows, side="right") - 1, 0, t.size - 1)
    behind = np.take_along_axis(running, last, axis=1)
    return q_at, p_at, np.mean(np.maximum(here, behind), axis=1)


def _curvature(dV_rows, q, force, step=1e-6):
    """V″ over each grid interval: the secant of the force between the interval's ends,
    which also sees a kink of V crossed inside it (V = |q − ½| has V″ = δ, and the
    secant integrates it); where the prediction hardly moves (|Δq̂| < 1e-6), the
    central difference of the force callable at the interval's middle. Shape
    (N, K − 1)."""
    dq = np.diff(q, axis=1)
    secant = np.diff(force, axis=1) / np.where(np.abs(dq) < step, 1.0, dq)
    still = np.abs(dq) < step
    cols = np.flatnonzero(still.any(axis=0))  # usually a few (the start, turning points)
    if cols.size:
        mid = 0.5 * (q[:, cols + 1] + q[:, cols])
        point = (dV_rows(mid + step) - dV_rows(mid - step)) / (2.0 * step)
        secant[:, cols] = np.where(still[:, cols], point, secant[:, cols])
    return secant


def propagated_error(d_q, d_p, curvature, t=TIMES):
    """The Picard defect carried through the flow linearised about a prediction.

    Solves w′ = J (w + d), w(0) = 0, J = [[0, 1], [−V″, 0]], on the grid ``t`` by the
    trapezoidal rule with V″ constant over each interval (second order and A-stable: a
    stiff V″ does not blow it up), so that d + w is the prediction's error to first
    order (:func:`estimate_at`).

    Args:
        d_q, d_p: (N, K) the signed Picard defect on the grid.
        curvature: (N, K − 1) V″ over each grid interval.
        t: (K,) increasing grid.

    Returns:
        (w_q, w_p): (N, K) each.

    Example:
        >>> t = np.linspace(0, 1, 201)  # a constant position defect, free particle
        >>> w_q, w_p = propagated_error(np.full((1, 201), 1e-3), np.zeros((1, 201)),
        ...                             np.zeros((1, 200)), t)
        >>> bool(np.allclose(w_q, 0) and np.allclose(w_p, 0))
        True
    """
    shape = np.shape(d_q)
    if np.shape(curvature) != (shape[0], shape[1] - 1):
        raise ValueError(f"curvature must have shape {(shape[0], shape[1] - 1)} (one value "
                         f"per grid interval), got {np.shape(curvature)}")
    w_q, w_p = np.empty(shape), np.empty(shape)
    _trapezoid(np.ascontiguousarray(t, dtype=np.float64),
               np.ascontiguousarray(d_q, dtype=np.float64),
               np.ascontiguousarray(d_p, dtype=np.float64),
               np.ascontiguousarray(curvature, dtype=np.float64), w_q, w_p)
    return w_q, w_p


@numba.njit(cache=True, nogil=True)
def _trapezoid(t, d_q, d_p, curv, w_q, w_p):
    for i in range(d_q.shape[0]):
        wq, wp = 0.0, 0.0
        w_q[i, 0], w_p[i, 0] = 0.0, 0.0
        for k in range(t.size - 1):
            h = 0.5 * (t[k + 1] - t[k])
            c1 = curv[i, k]
            rq = wq + h * (wp + d_p[i, k] + d_p[i, k + 1])
            rp = wp - h * c1 * (wq + d_q[i, k] + d_q[i, k + 1])
            det = 1.0 + h * h * c1  # (I − h J₁) w₁ = r, solved in closed form
            wq, wp = (rq + h * rp) / det, (rp - h * c1 * rq) / det
            w_q[i, k + 1], w_p[i, k + 1] = wq, wp


def sensor_force(V):
    """(V_rows, dV_rows) of the not-a-knot splines through sensor values V (N, 100)."""
    from ..solvers import sensor_spline_params

    params = sensor_spline_params(np.atleast_2d(V))
    return (lambda q: spline_rows(params, q, 0)), (lambda q: spline_rows(params, q, 1))


def exact_force(pot):
    """(V_rows, dV_rows) of an exact potential ``pot`` (with ``V`` and ``dV`` of flat
    points), for arrays of any shape."""
    return _rows(pot.V), _rows(pot.dV)


def _rows(fn):
    return lambda x: np.asarray(fn(x.reshape(-1)), dtype=np.float64).reshape(x.shape)
