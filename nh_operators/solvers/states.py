"""Starting states (q0, p0): broadcast to rows and checked against the walls of [0, 1].

V is defined on [0, 1] only, with V(0) = V(1) = V0 and V < V0 inside. A particle stays
inside exactly when its energy E = p0²/2 + V(q0) is at most V0 (then it turns around
before, or at, a wall). The paper's state (0, 0) has E = V(0) = V0 and is always allowed,
as is any other state at rest on a wall.
"""

import math

import numpy as np

from .._constants import V0
from .row_error import RowError

__all__ = ["STATE_ATOL", "STATE_UNIFORMS", "check_states", "energy_states", "random_states",
           "state_arrays"]

#: Energy above V0 that is still accepted (rounding of p0²/2 + V(q0)).
STATE_ATOL = 1e-12


def state_arrays(q0, p0, n):
    """q0 and p0 as float64 arrays of shape (n,): scalars are repeated on every row.

    Args:
        q0, p0: scalars or arrays of shape (n,).
        n: the number of rows.

    Returns:
        (q0s, p0s): two float64 arrays (n,).

    Raises:
        ValueError: for a wrong shape or a value that is not finite.

    Example:
        >>> q0s, p0s = state_arrays(0.5, [0.0, 1.0], 2)
        >>> q0s.tolist(), p0s.tolist()
        ([0.5, 0.5], [0.0, 1.0])
    """
    out = []
    for name, value in (("q0", q0), ("p0", p0)):
        if type(value) is float and math.isfinite(value):  # the usual case, cheaply
            out.append(np.full(n, value))
            continue
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a number or one number per row, got "
                             f"{type(value).__name__}") from None
        if arr.ndim == 0:
            arr = np.full(n, float(arr))
        elif arr.shape != (n,):
            raise ValueError(f"{name} must be a scalar or have one value per row, shape "
                             f"({n},); got shape {arr.shape}")
        bad = np.flatnonzero(~np.isfinite(arr))
        if bad.size:
            where = f"[{bad[0]}]" if n > 1 else ""
            raise ValueError(f"{name}{where} = {arr[bad[0]]} is not finite")
        out.append(np.ascontiguousarray(arr))
    return out[0], out[1]


def check_states(q0s, p0s, value_at, batched=False):
    """Check that every state stays inside [0, 1]; return the energies.

    Args:
        q0s, p0s: (N,) arrays (see :func:`state_arrays`).
        value_at: callable mapping the (N,) positions q0s to V of each row there.
        batched: name rows in the messages.

    Returns:
        (N,) energies p0²/2 + V(q0).

    Raises:
        RowError: for q0 outside [0, 1], or an energy above V0 (the message names the
            energy and the wall the particle would cross; ``row`` the row when batched).

    Example:
        >>> check_states(np.array([0.5]), np.array([3.0]),
        ...              lambda q: 8 * (q - 0.5) ** 2)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        nh_operators.solvers.row_error.RowError: the state (q0 = 0.5, p0 = 3) has energy ...
    """
    inside = (q0s >= 0.0) & (q0s <= 1.0)  # NaN is not
    if not inside.all():
        i = int(np.argmin(inside))
        raise RowError(f"q0 = {q0s[i]:g} is outside [0, 1], where V is defined",
                       row=i if batched else None)
    with np.errstate(all="ignore"):
        energy = 0.5 * p0s**2 + np.asarray(value_at(q0s), dtype=np.float64).reshape(-1)
    below = energy <= V0 + STATE_ATOL  # NaN is not
    if below.all():  # the usual case: no wall test
        return energy
    at_rest_on_wall = (p0s == 0.0) & ((q0s == 0.0) | (q0s == 1.0))
    bad = np.flatnonzero(~below & ~at_rest_on_wall)
    if bad.size:
        i = bad[0]
        wall = ("q = 1" if p0s[i] > 0 else "q = 0" if p0s[i] < 0
                else "q = 0 and q = 1")
        raise RowError(f"the state (q0 = {q0s[i]:g}, p0 = {p0s[i]:g}) has energy "
                       f"p0²/2 + V(q0) = {energy[i]:.10g} > V0 = {V0:g}: the particle would "
                       f"cross the wall at {wall} and leave [0, 1], where V is defined",
                       row=int(i) if batched else None)
    return energy


def random_states(value_at, n, rng):
    """Random bounded starting states, one per row: q0 uniform among the points of
    [0, 1] where V < V0, the energy uniform in [V(q0), V0], the sign of p0 random.

    Args:
        value_at: ``value_at(x, rows=...)`` -> V of the rows ``rows`` at x, as a row
            source's :meth:`~nh_operators.solvers.rows.RowSource.values_at`.
        n: rows.
        rng: a ``numpy.random.Generator``.

    Returns:
        (q0, p0), two (n,) arrays.

    Example:
        >>> from nh_operators.solvers.rows import row_source
        >>> src = row_source("sho", "exact V")
        >>> q0, p0 = random_states(lambda x, rows: src.values_at(x), 3, np.random.default_rng(0))
        >>> bool(np.all(0.5 * p0**2 + 8 * (q0 - 0.5) ** 2 <= V0))
        True
    """
    q0, p0 = np.empty(n), np.empty(n)
    for i in range(n):
        while True:
            q = rng.uniform(0.0, 1.0)
            v = float(value_at(np.array([q]), rows=np.array([i]))[0])
            if v < V0:
                break
        q0[i] = q
        p0[i] = rng.choice([-1.0, 1.0]) * np.sqrt(2.0 * rng.uniform(0.0, V0 - v))
    return q0, p0


#: Uniform numbers one state of :func:`energy_states` consumes.
STATE_UNIFORMS = 5


def energy_states(values, uniforms, *, separatrix_share=0.25, grid=1025):
    """Starting states stratified by energy, one per row, from given uniform numbers.

    Uniform in energy rather than in q0: the energy E is uniform in [V_min, V0] (V_min the
    row's minimum), except that with probability ``separatrix_share``, on a row whose V
    has an interior local maximum V_s, E lies within 1e-4..1e-1 of (V0 − V_min) of V_s
    (log-uniform, either side): the slow orbits near a separatrix, which a uniform energy
    would make rare. q0 is then uniform over the points where V ≤ E and p0 = ±√(2(E −
    V(q0))). Every row consumes exactly :data:`STATE_UNIFORMS` numbers, so a stream of
    rows gives the same states however it is cut into batches.

    Args:
        values: callable mapping an (N, G) array of positions to V of row i at row i's
            positions.
        uniforms: (N, STATE_UNIFORMS) numbers in [0, 1).
        separatrix_share: the share of near-separatrix draws, in [0, 1].
        grid: points of the uniform grid on [0, 1] that locates V_min, the maxima and the
            set V ≤ E (the state's own energy is exact, whatever the grid).

    Returns:
        (q0, p0, near): (N,) arrays; ``near`` is True for a near-separatrix draw.

    Raises:
        ValueError: for a share outside [0, 1] or uniforms of the wrong shape.

    Example:
        >>> sho = lambda x: 8 * (x - 0.5) ** 2
        >>> u = np.random.default_rng(0).random((4, STATE_UNIFORMS))
        >>> q0, p0, near = energy_states(sho, u)
        >>> bool(np.all(0.5 * p0**2 + sho(q0) <= V0)), near.tolist()  # no maximum inside
        (True, [False, False, False, False])
    """
    if not 0.0 <= separatrix_share <= 1.0:
        raise ValueError(f"separatrix_share must be in [0, 1], got {separatrix_share}")
    uniforms = np.asarray(uniforms, dtype=np.float64)
    if uniforms.ndim != 2 or uniforms.shape[1] != STATE_UNIFORMS:
        raise ValueError(f"uniforms must have shape (N, {STATE_UNIFORMS}), got "
                         f"{uniforms.shape}")
    n = uniforms.shape[0]
    x = np.linspace(0.0, 1.0, grid)
    v = np.asarray(values(np.broadcast_to(x, (n, grid))), dtype=np.float64)
    kind, level, which, where, sign = uniforms.T
    v_min = v.min(axis=1)
    energy = v_min + level * (V0 - v_min)
    near = np.zeros(n, dtype=bool)
    inner = v[:, 1:-1]
    peaks = (inner > v[:, :-2]) & (inner >= v[:, 2:])
    for i in np.flatnonzero((kind < separatrix_share) & peaks.any(axis=1)):
        js = np.flatnonzero(peaks[i]) + 1
        j = js[min(int(which[i] * js.size), js.size - 1)]
        a, b, c = v[i, j - 1], v[i, j], v[i, j + 1]  # the parabola's top through 3 points
        curv = a - 2 * b + c
        top = b - (c - a) ** 2 / (8 * curv) if curv < 0 else b
        side = 1.0 if level[i] >= 0.5 else -1.0
        gap = 10.0 ** (-4.0 + 3.0 * (2.0 * level[i] % 1.0)) * (V0 - v_min[i])
        energy[i] = min(max(top + side * gap, v_min[i]), V0)
        near[i] = True
    q0 = np.empty(n)
    cells = (v[:, :-1] <= energy[:, None]) | (v[:, 1:] <= energy[:, None])
    for i in range(n):
        allowed = np.flatnonzero(cells[i])
        pos = where[i] * allowed.size
        k = min(int(pos), allowed.size - 1)
        q0[i] = x[allowed[k]] + (pos - k) * (x[1] - x[0])
    v0 = np.asarray(values(q0[:, None]), dtype=np.float64)[:, 0]
    p0 = np.where(sign < 0.5, -1.0, 1.0) * np.sqrt(2.0 * np.maximum(energy - v0, 0.0))
    return q0, p0, near
