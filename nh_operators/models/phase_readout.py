"""PhaseONet's read-out as one compiled loop: the half-phase, the two grid nodes, the lerp
and the sign of p, per asked time, with no intermediate (B, M) tensors.

Read by torch operations (:meth:`~.phase_head.BasisHeadNet.read_half_phase`), the
read-out at batch 1,000 and 100 times is about fifteen passes over (B, M) arrays (the
phase, its fraction, sign and distance, floor, clamp, the integer nodes, four gathers,
two lerps, the stack) and costs more than the MLP and the period together. Here each
output value is computed once, from the row's rate 1/T, its phase offset and the time.
The phase is computed in float64 (torch's path does so only for times beyond 16), so the
two paths agree to the tables' precision, not bit for bit.

:meth:`~.phase_head.BasisHeadNet.read_orbit` takes this path on the CPU when no gradient
flows through the tables or the rate; training and other devices keep the torch path.
"""

import numba
import numpy as np

__all__ = ["PARALLEL_FROM", "read_orbit_rows"]

#: Rows from which the read-out runs on numba's threads (fewer: one thread, no launch).
PARALLEL_FROM = 64


@numba.njit(cache=True, nogil=True, inline="always")
def _read_row(q_table, p_table, rate, offset, t, out):  # pragma: no cover - compiled
    """One row: ``out[m, 0] = Q(h(u_m))`` and ``out[m, 1] = sign · P(h(u_m))`` (when
    ``out`` has two columns), u_m = rate · t[m] + offset."""
    last = q_table.shape[0] - 1
    for m in range(t.shape[0]):
        u = rate * t[m] + offset
        d = (u - np.trunc(u)) - 0.5                 # torch.frac: u − trunc(u)
        x = last - 2.0 * last * abs(d)              # grid coordinate of h = 1/2 − |d|
        k = min(max(int(x), 0), last - 1)           # x ≥ 0 for u ≥ 0: int() is floor
        w = min(x - k, 1.0)
        a = q_table[k]
        out[m, 0] = a + w * (q_table[k + 1] - a)
        if out.shape[1] == 2:
            a = p_table[k]
            # + while the phase is below 1/2 (d < 0), − after, 0 at 1/2
            out[m, 1] = (np.sign(-d)) * (a + w * (p_table[k + 1] - a))


@numba.njit(cache=True, nogil=True)
def _rows_serial(q, p, rate, offset, t, out):  # pragma: no cover - compiled
    for r in range(q.shape[0]):
        _read_row(q[r], p[r], rate[r], offset[r], t, out[r])


@numba.njit(cache=True, nogil=True, parallel=True)
def _rows_parallel(q, p, rate, offset, t, out):  # pragma: no cover - compiled
    for r in numba.prange(q.shape[0]):
        _read_row(q[r], p[r], rate[r], offset[r], t, out[r])


def read_orbit_rows(q: np.ndarray, p: np.ndarray, rate: np.ndarray, offset: np.ndarray,
                    t: np.ndarray, n_outputs: int) -> np.ndarray:
    """The half-orbit tables read at the phases u = rate · t + offset of every row.

    Args:
        q, p: (B, grid) the tables of Q and abs(P) on h ∈ [0, 1/2] (``p`` unused when
            ``n_outputs`` is 1; pass ``q``), C-contiguous, float32 or float64.
        rate: (B,) float64, 1 / T.
        offset: (B,) float64, the phase at t = 0.
        t: (M,) float64 times.
        n_outputs: 2 (q and p) or 1 (q).

    Returns:
        (B, M, n_outputs) in the tables' dtype: q = Q(h) and p = ± P(h), the sign + while
        the phase mod 1 is below 1/2, − after, 0 exactly at 1/2.

    Example:
        >>> table = np.linspace(0.0, 1.0, 3)[None]            # Q(h) = 2h on 3 nodes
        >>> read_orbit_rows(table, table, np.array([1.0]), np.zeros(1),
        ...                 np.array([0.25, 0.75]), 2).round(6).tolist()
        [[[0.5, 0.5], [0.5, -0.5]]]
    """
    out = np.empty((q.shape[0], t.shape[0], n_outputs), dtype=q.dtype)
    kernel = (_rows_parallel if q.shape[0] >= PARALLEL_FROM and numba.get_num_threads() > 1
              else _rows_serial)
    kernel(q, p, rate, offset, t, out)
    return out
