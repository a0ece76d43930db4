"""A compiled function of V evaluated on many rows at once: V or −V′ of row i at its points.

:func:`pairwise` gives ``fn(pars[i], xs[i])`` and :func:`rowwise` ``fn(pars[i], xs[i, j])``
for a compiled ``fn(par, x)`` (a B-spline's, the sensor spline's or a compiled formula's
value or force), in one call. Each is a template compiled once per function
(:func:`~nh_operators.potentials._spline_kernels.specialised`) and cached on disk: a
compiled call costs a few µs to dispatch, more than the M evaluations of a short row, so
one call per (N, M) array instead of one per row.
"""

import numba

from ..potentials._spline_kernels import FN, specialised

__all__ = ["pairwise", "rowwise"]


def _pairwise(pars, xs, out):
    for i in numba.prange(xs.shape[0]):
        out[i] = FN(pars[i], xs[i])


def _rowwise(pars, xs, out):
    last = pars.shape[0] - 1
    for i in range(xs.shape[0]):
        par = pars[min(i, last)]
        for j in range(xs.shape[1]):
            out[i, j] = FN(par, xs[i, j])


def pairwise(fn, pars, xs, out):
    """out[i] = fn(pars[i], xs[i]).

    Args:
        fn: a compiled ``fn(par, x)``.
        pars: (N, P) float64 parameters; xs: (N,) points; out: (N,) float64, filled.
    """
    specialised(_pairwise, {"FN": fn}, parallel=True)(pars, xs, out)


def rowwise(fn, pars, xs, out):
    """out[i, j] = fn(pars[i], xs[i, j]); one row of ``pars`` serves every row.

    Args:
        fn: a compiled ``fn(par, x)``.
        pars: (N, P) or (1, P) float64 parameters; xs: (N, M) points; out: (N, M)
            float64, filled.
    """
    specialised(_rowwise, {"FN": fn})(pars, xs, out)
