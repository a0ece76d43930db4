"""Hamilton's equations solved by Chebyshev collocation and Newton's method, from a guess.

What: :func:`newton_collocation` turns a guessed trajectory q(t) on [0, T] into the
solution of dq/dt = p, dp/dt = −V'(q) with q(0) = q0, p(0) = p0, represented by its
values at the N + 1 Chebyshev–Lobatto points; :func:`collocate` doubles N until the
Chebyshev coefficients say the trajectory is resolved to a tolerance.

The math: at the points t_j = T (1 − cos(πj/N)) / 2 the derivative is the matrix D of the
interpolating polynomial. With p = D q at t_1..t_N (p_0 = p0 given) the equations are

    F(q) = D[1:, 0] p0 + D[1:, 1:] D[1:, :] q + V'(q[1:]) = 0,    q_0 = q0,

N equations in q_1..q_N. Newton's step solves (D[1:, 1:] D[1:, 1:] + diag V''(q)) Δ = F.
The Jacobian only steers the steps: an approximate V'' (a difference of V') changes how
fast the steps converge, not what they converge to. The error estimate of a level is the
larger of the size of its last Chebyshev coefficients and its largest difference from the
level with half the points (which bounds the coarser level's error, so it is pessimistic
for a smooth trajectory, and stays honest for one of limited smoothness, whose
coefficients decay slowly: a trajectory of a splined potential). A trajectory is
accepted when Newton's steps have stopped (|Δ| ≤ 1e-12) and the estimate, from at least
two levels, is below the tolerance.

Why: Newton's method on a whole oscillating horizon converges only from a guess close to
the answer, which is what a trained network gives. Refining the trajectory, rather than
the network's weights, keeps what the network got right and costs a few small linear
solves (:func:`nh_operators.refine` with ``method="newton"``).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import numpy as np
import scipy.fft
import scipy.linalg

__all__ = ["Collocation", "chebyshev_points", "collocate", "collocation_residual",
           "newton_collocation"]

Force = Callable[[np.ndarray], np.ndarray]


@dataclasses.dataclass(frozen=True)
class Collocation:
    """A trajectory on Chebyshev–Lobatto points, and how it was found.

    Attributes:
        t, q, p: (N + 1,) the points on [0, T] and the solution there.
        steps: Newton steps taken (all levels of :func:`collocate` together).
        estimate: size of the trajectory's last Chebyshev coefficients (max over q, p):
            what is left unresolved at this N; from :func:`collocate`, also at least the
            largest difference from the level with half the points.
        converged: True when Newton's steps stopped and, for :func:`collocate`, the
            estimate met the tolerance.
    """

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray
    steps: int
    estimate: float
    converged: bool

    def __call__(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(q, p) at the times ``t`` (in [0, T]) by barycentric interpolation."""
        w = _weights(self.t.size - 1)
        return _barycentric(self.t, w, self.q, t), _barycentric(self.t, w, self.p, t)


def chebyshev_points(n: int, t_end: float) -> np.ndarray:
    """The n + 1 Chebyshev–Lobatto points on [0, t_end], increasing.

    Example:
        >>> chebyshev_points(2, 2.0)
        array([0., 1., 2.])
    """
    return t_end * (1.0 - np.cos(np.pi * np.arange(n + 1) / n)) / 2.0


@functools.lru_cache(maxsize=16)
def _operators(n: int, t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """(D (n+1, n+1), D[1:, 1:] D[1:, :] (n, n+1)) on [0, t_end]."""
    t = chebyshev_points(n, t_end)
    c = np.ones(n + 1)
    c[[0, -1]] = 2.0
    c *= (-1.0) ** np.arange(n + 1)
    diff = t[:, None] - t[None, :]
    D = np.outer(c, 1.0 / c) / (diff + np.eye(n + 1))
    D -= np.diag(D.sum(axis=1))  # each row of D annihilates constants
    return D, D[1:, 1:] @ D[1:, :]


def collocation_residual(q: np.ndarray, p: np.ndarray, t_end: float, dV: Force) -> float:
    """Mean squared residual of Hamilton's equations of the interpolants of (q, p).

    Args:
        q, p: (N + 1,) values at :func:`chebyshev_points` (N, t_end).
        t_end: T.
        dV: V'(q), vectorised.

    Returns:
        (mean (Dq − p)² + mean (Dp + V'(q))²) / 2 over the N + 1 points.

    Example:
        >>> t = chebyshev_points(24, 2.0)
        >>> r = collocation_residual(0.5 - 0.5 * np.cos(4 * t), 2 * np.sin(4 * t), 2.0,
        ...                          lambda q: 16 * (q - 0.5))
        >>> bool(r < 1e-12)
        True
    """
    D = _operators(q.size - 1, float(t_end))[0]
    return float(0.5 * (np.mean((D @ q - p) ** 2) + np.mean((D @ p + dV(q)) ** 2)))


@functools.lru_cache(maxsize=16)
def _weights(n: int) -> np.ndarray:
    w = (-1.0) ** np.arange(n + 1)
    w[[0, -1]] /= 2.0
    return w


def _barycentric(nodes: np.ndarray, w: np.ndarray, values: np.ndarray,
                 t: np.ndarray) -> np.ndarray:
    t = np.asarray(t, dtype=np.float64)
    diff = t[:, None] - nodes[None, :]
    exact = diff == 0.0
    diff[exact] = 1.0
    ratio = w / diff
    out = (ratio @ values) / ratio.sum(axis=1)
    rows, cols = np.nonzero(exact)
    out[rows] = values[cols]
    return out


def _tail(values: np.ndarray) -> float:
    """Size of the last three Chebyshev coefficients of the interpolant of ``values``."""
    n = values.size - 1
    coefficients = np.asarray(scipy.fft.dct(values, type=1)) / n
    coefficients[[0, -1]] /= 2.0
    return float(np.abs(coefficients[-3:]).max())


def newton_collocation(dV: Force, d2V: Force, q_guess: np.ndarray, t_end: float,
                       q0: float = 0.0, p0: float = 0.0, *, max_steps: int = 30,
                       step_tol: float = 1e-12, unresolved_above: float = 0.0
                       ) -> Collocation:
    """Newton's method on the collocation equations at the N + 1 points of ``q_guess``.

    Args:
        dV: V'(q), vectorised over q.
        d2V: V''(q) (or an approximation of it: it only steers the steps).
        q_guess: (N + 1,) the guess at :func:`chebyshev_points` (N, t_end); its first
            value is replaced by q0.
        t_end: T, the end of the horizon.
        q0, p0: the starting state.
        max_steps: Newton steps at most.
        step_tol: stop when the largest step is below this (relative to max(1, max abs(q))).
            Also stop, converged, at the rounding floor: when a step below
            eps · N² (relative) is no smaller than half the one before, Newton's
            quadratic convergence has ended in rounding (on the SMFF at N = 512 the
            steps stalled at 1.2e-12 to 6.5e-12 on one CPU, just above 1e-12).
        unresolved_above: if positive, also stop once the points cannot resolve the
            trajectory to this (their Chebyshev tail is above it) and the step is below a
            tenth of that tail: a finer level will be needed, and more steps here would
            only polish a guess.

    Returns:
        A :class:`Collocation` (``converged`` False when the steps did not stop or left
        the finite numbers).

    Raises:
        ValueError: for fewer than 4 points or a non-positive horizon.

    Example:
        >>> sol = newton_collocation(lambda q: 16 * (q - 0.5), lambda q: 16 + 0 * q,
        ...                          np.zeros(33), 2.0)
        >>> error = abs(sol(np.array([1.0]))[0][0] - (0.5 - 0.5 * np.cos(4.0)))
        >>> bool(sol.converged), bool(error < 1e-10)
        (True, True)
    """
    q = np.array(q_guess, dtype=np.float64)
    n = q.size - 1
    if n < 3 or not t_end > 0:
        raise ValueError(f"collocation needs at least 4 points and T > 0, got {n + 1} "
                         f"points and T = {t_end}")
    D, M = _operators(n, float(t_end))
    q[0] = q0
    J0 = M[:, 1:]
    steps, converged = 0, False
    # the steps' rounding floor: the collocation matrix's condition grows like N²
    floor, previous = np.finfo(np.float64).eps * n * n, np.inf
    while steps < max_steps:
        F = D[1:, 0] * p0 + M @ q + dV(q[1:])
        J = J0 + np.diag(d2V(q[1:]))
        try:
            delta = scipy.linalg.solve(J, F, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            break
        q[1:] -= delta
        steps += 1
        size = float(np.abs(delta).max())
        if not np.isfinite(size):
            break
        scale = max(1.0, float(np.abs(q).max()))
        if size <= step_tol * scale or (size <= floor * scale and size >= 0.5 * previous):
            converged = True
            break
        previous = size
        if unresolved_above > 0:
            tail = _tail(q)
            if tail > unresolved_above and size < 0.1 * tail:
                converged = True
                break
    p = np.concatenate([[p0], (D @ q)[1:]])
    estimate = max(_tail(q), _tail(p)) if np.all(np.isfinite(q)) else float("inf")
    return Collocation(chebyshev_points(n, t_end), q, p, steps, estimate,
                       converged and np.isfinite(estimate))


def collocate(dV: Force, d2V: Force, guess: Callable[[np.ndarray], np.ndarray],
              t_end: float, q0: float = 0.0, p0: float = 0.0, *, tol: float = 1e-10,
              n_start: int = 32, n_max: int = 512) -> Collocation:
    """Collocation with N doubled until the trajectory is resolved to ``tol``.

    The first level starts from ``guess`` (a function of t: a network's prediction);
    each finer level starts from the coarser level's solution. A level is accepted only
    after a coarser one, since its estimate includes their difference.

    Args:
        dV, d2V: V' and (an approximation of) V''.
        guess: q(t) guessed, vectorised over t in [0, t_end].
        t_end: T.
        q0, p0: the starting state.
        tol: accept when the last Chebyshev coefficients are below it.
        n_start, n_max: the first and largest N.

    Returns:
        The last level's :class:`Collocation`; ``converged`` False when N reached
        ``n_max`` without meeting ``tol``, or when Newton failed at a level (the answer
        is then the coarser level's, the last whose Newton steps stopped).

    Raises:
        ValueError: for a non-positive ``tol`` or ``n_start`` < 3.
    """
    if not tol > 0 or n_start < 3:
        raise ValueError(f"tol must be positive and n_start ≥ 3, got {tol}, {n_start}")
    n, steps = int(n_start), 0
    q_guess = np.asarray(guess(chebyshev_points(n, t_end)), dtype=np.float64)
    coarser: Collocation | None = None
    while True:
        sol = newton_collocation(dV, d2V, q_guess, t_end, q0, p0, unresolved_above=tol)
        steps += sol.steps
        estimate = sol.estimate
        if coarser is not None:  # what the coarser level got wrong bounds this one's error
            q_c, p_c = coarser(sol.t)
            estimate = max(estimate, float(np.abs(sol.q - q_c).max()),
                           float(np.abs(sol.p - p_c).max()))
        sol = dataclasses.replace(sol, steps=steps, estimate=estimate)
        done = sol.converged and coarser is not None and estimate <= tol
        if not sol.converged and coarser is not None:  # Newton failed here: the last
            return dataclasses.replace(coarser, steps=steps, converged=False)  # that held
        if done or not sol.converged or 2 * n > n_max:
            return dataclasses.replace(sol, converged=done)
        n *= 2
        coarser = sol
        q_guess = sol(chebyshev_points(n, t_end))[0]
