"""The asked order of a row solve's times: sorted for the solve, put back for the answer.

:func:`~nh_operators.solvers.rows.solve_rows` integrates each row through its times in
increasing order (a plan may add a working time and reduce times into one period,
:mod:`.periodic`), then answers in the order the times were asked. These three steps
do that bookkeeping, apart from the solve.
"""

import numpy as np

__all__ = ["asked_columns", "in_asked_order", "sorted_times"]


def sorted_times(t: np.ndarray, n: int) -> tuple[np.ndarray | None, np.ndarray]:
    """Each row's times sorted.

    Args:
        t: (M,) times shared by the ``n`` rows, or (N, M) per row.
        n: the number of rows N.

    Returns:
        (asked_order, ts): the order that sorts each row (N, M) and the sorted times
        (N, M); broadcast views of one row when ``t`` is shared, and ``asked_order``
        None when the shared times were asked in increasing order (``ts`` then views
        ``t``).
    """
    if t.ndim == 1 and bool((t[1:] >= t[:-1]).all()):  # shared and already sorted
        if n > 1:
            return None, np.broadcast_to(t, (n, t.size))
        ts = t[None]
        ts.flags.writeable = False  # a view of the caller's times, as the broadcast is
        return None, ts
    if t.ndim == 1:  # times shared by every row: sort once
        order = np.argsort(t, kind="stable")
        if n == 1:  # a view of one row is cheaper than a broadcast
            return order[None], t[order][None]
        asked_order = np.broadcast_to(order, (n, t.size))
        ts = np.broadcast_to(t[order], (n, t.size))
    else:
        asked_order = np.argsort(t, axis=1, kind="stable")
        ts = np.take_along_axis(t, asked_order, axis=1)
    return asked_order, ts


def asked_columns(q: np.ndarray, p: np.ndarray, column: np.ndarray | None,
                  m: int) -> tuple[np.ndarray, np.ndarray]:
    """(q, p) at the M sorted asked times, from the states at the working times.

    Args:
        q, p: (N, W) the states at the working times.
        column: (N, M + 1) the working column of each sorted asked time, or None when
            the working times are the asked ones.
        m: the number of asked times M.

    Returns:
        (q, p), each (N, M); ``q`` and ``p`` themselves when ``column`` is None.
    """
    if column is None:  # the work columns are the asked ones
        return q, p
    return (np.take_along_axis(q, column[:, :m], 1),
            np.take_along_axis(p, column[:, :m], 1))


def in_asked_order(qa: np.ndarray, pa: np.ndarray, asked_order: np.ndarray | None,
                   ndim: int) -> tuple[np.ndarray, np.ndarray]:
    """The states at the sorted times put back in the asked order.

    Args:
        qa, pa: (N, M) the states at the sorted asked times.
        asked_order: (N, M) the order of :func:`sorted_times` (None: asked sorted).
        ndim: 1 when the times were shared by every row (one order for all), else 2.

    Returns:
        (q, p), each (N, M) in the asked order: ``qa`` and ``pa`` themselves when the
        shared times were asked in order, else new arrays.
    """
    if asked_order is None:
        return qa, pa  # asked sorted: nothing to put back
    n, m = qa.shape
    q_final, p_final = np.empty((n, m)), np.empty((n, m))
    if ndim == 1:
        q_final[:, asked_order[0]], p_final[:, asked_order[0]] = qa, pa
    else:
        np.put_along_axis(q_final, asked_order, qa, 1)
        np.put_along_axis(p_final, asked_order, pa, 1)
    return q_final, p_final
