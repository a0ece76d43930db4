"""Clamped uniform cubic B-splines in power form, and the packed layout the kernels read.

A potential of the generator is the planar curve (q(λ), V(λ)), λ ∈ [0, 1], a clamped
cubic B-spline through ``C = n_grf + 2`` control points with uniform interior knots. It
has ``S = C - 3`` polynomial pieces on λ ∈ [j/S, (j+1)/S]; on piece j, with local
variable s = λ S - j ∈ [0, 1], both coordinates are cubics a0 + a1 s + a2 s² + a3 s³.

Packed parameters (one float64 row of length :data:`PACKED_SIZE` per potential):
``[S, q-coefficients (MAX_PIECES × 4), V-coefficients (MAX_PIECES × 4)]``; unused
pieces hold zeros.
"""

import functools

import numpy as np

DEGREE = 3
MAX_CONTROL = 9  # n_grf ≤ 7 interior control points plus the two ends
MAX_PIECES = MAX_CONTROL - DEGREE
PACKED_SIZE = 1 + 8 * MAX_PIECES
Q_OFFSET = 1
V_OFFSET = 1 + 4 * MAX_PIECES


def clamped_knots(n_control):
    """Knot vector of a clamped uniform cubic B-spline with ``n_control`` control points.

    Example:
        >>> clamped_knots(5).tolist()
        [0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0]
    """
    if n_control < DEGREE + 1:
        raise ValueError(f"a cubic B-spline needs at least 4 control points, got {n_control}")
    pieces = n_control - DEGREE
    inner = np.linspace(0.0, 1.0, pieces + 1)
    return np.concatenate([np.zeros(DEGREE), inner, np.ones(DEGREE)])


@functools.lru_cache(maxsize=None)
def power_matrix(n_control):
    """Linear map from control values to power coefficients, shape (S, 4, n_control).

    ``coef[j, k] = sum_c M[j, k, c] * P[c]`` is the coefficient of s**k on piece j.
    """
    from scipy.interpolate import PPoly  # only here: a slow import (0.5-1 s)

    knots = clamped_knots(n_control)
    pieces = n_control - DEGREE
    out = np.zeros((pieces, 4, n_control))
    for c in range(n_control):
        unit = np.zeros(n_control)
        unit[c] = 1.0
        pp = PPoly.from_spline((knots, unit, DEGREE))
        keep = np.diff(pp.x) > 0  # drop the zero-length intervals of the clamped ends
        coef = pp.c[:, keep]  # (4, S), highest power first, in powers of (λ - λ_j)
        for k in range(4):
            out[:, k, c] = coef[DEGREE - k] * (1.0 / pieces) ** k
    out.setflags(write=False)
    return out


def pack(control_q, control_V):
    """Pack control points into kernel parameters.

    Args:
        control_q: (N, MAX_CONTROL) control abscissae, NaN-padded after the last one.
        control_V: (N, MAX_CONTROL) control values, padded the same way.

    Returns:
        float64 array of shape (N, PACKED_SIZE).
    """
    control_q = np.atleast_2d(np.asarray(control_q, dtype=np.float64))
    control_V = np.atleast_2d(np.asarray(control_V, dtype=np.float64))
    counts = np.sum(np.isfinite(control_q), axis=1)
    packed = np.zeros((control_q.shape[0], PACKED_SIZE))
    for n_control in np.unique(counts):
        rows = np.flatnonzero(counts == n_control)
        matrix = power_matrix(int(n_control))
        pieces = matrix.shape[0]
        cq = np.einsum("jkc,nc->njk", matrix, control_q[rows, :n_control])
        cv = np.einsum("jkc,nc->njk", matrix, control_V[rows, :n_control])
        packed[rows, 0] = pieces
        packed[rows, Q_OFFSET : Q_OFFSET + 4 * pieces] = cq.reshape(len(rows), -1)
        packed[rows, V_OFFSET : V_OFFSET + 4 * pieces] = cv.reshape(len(rows), -1)
    return packed
