"""Compiled (numba) piecewise-cubic potentials: clamped B-spline curves and cubics on a q-grid.

Every force function has the signature ``force(params, x) -> -V'(x)`` with ``params``
a 1-D float64 row; the solvers' kernels (:mod:`nh_operators.solvers._kernels`) run one
specialisation per force (:func:`specialised`), cached on disk across processes.

**Where the compiled code is kept.** numba writes a kernel's cache (``*.nbi`` index,
``*.nbc`` data) to the first of: ``$NUMBA_CACHE_DIR`` if set; the ``__pycache__`` folder
next to the source file if it is writable (a checkout, a user install); numba's folder
in the user's cache directory (``~/.cache/numba`` on Linux, a subfolder per package
path) when site-packages is read-only. If none is writable, nothing is cached and every
process compiles again (5–15 s before its first answer).
"""

import hashlib
import math
import os
import types
from typing import Any

import numba

from .bspline import Q_OFFSET, V_OFFSET

#: The ``numba.njit`` options of every cached kernel of the package.
JIT: dict[str, Any] = dict(nogil=True, cache=True)
#: The options of a kernel that takes a compiled function as an argument. Such a kernel
#: cannot be cached: numba keys its entries by the argument's dispatcher object, which is
#: new in every process (entries never match again, the index grows, saving it eventually
#: fails). Such kernels (the steppers, the period quadrature) are inlined instead into the
#: *specialised* kernels of :func:`specialised`, which call the function by a global name
#: and are cached.
JIT_FN_ARG: dict[str, Any] = dict(nogil=True, inline="always")

#: The names a kernel template calls (``FORCE(par, x)``...); :func:`specialised` binds
#: them to compiled functions.
FN: Any = None
FORCE: Any = None
VALUE: Any = None


@numba.njit(**JIT)
def cubic(c, o, s):
    """The cubic with coefficients ``c[o:o + 4]`` (constant first) at ``s``."""
    return c[o] + s * (c[o + 1] + s * (c[o + 2] + s * c[o + 3]))


@numba.njit(**JIT)
def dcubic(c, o, s):
    """The derivative in ``s`` of :func:`cubic`."""
    return c[o + 1] + s * (2.0 * c[o + 2] + s * 3.0 * c[o + 3])


@numba.njit(**JIT)
def _d2cubic(c, o, s):
    return 2.0 * c[o + 2] + 6.0 * s * c[o + 3]


# ---------------------------------------------------------------- B-spline potentials


@numba.njit(**JIT)
def bspline_locate(par, x):
    """Return (piece offset, s) with q(s) = x on that piece, by safeguarded Newton.

    Newton from the chord's guess, bisection where a step leaves the bracket; it stops
    when q(s) = x exactly, after a Newton step of at most 4 ulps of 1 + |s|, or when the
    bracket is that narrow.
    """
    pieces = int(par[0])
    j = 0
    for jj in range(1, pieces):
        if par[Q_OFFSET + 4 * jj] <= x:
            j = jj
        else:
            break
    oq = Q_OFFSET + 4 * j
    q_lo = par[oq]
    q_hi = cubic(par, oq, 1.0)
    if x < q_lo:  # left of the curve: extrapolate the first piece
        lo, hi = -1.0, 0.0
    elif x > q_hi:  # right of the curve: extrapolate the last piece
        lo, hi = 1.0, 2.0
    else:
        lo, hi = 0.0, 1.0
    s = (x - q_lo) / (q_hi - q_lo)
    s = min(max(s, lo), hi)
    for _ in range(100):
        g = cubic(par, oq, s) - x
        if g == 0.0:
            break
        if g > 0.0:
            hi = s
        else:
            lo = s
        d = dcubic(par, oq, s)
        step = g / d if d > 0.0 else 2.0 * (hi - lo)
        s_new = s - step
        if not (lo <= s_new <= hi):
            s_new = 0.5 * (lo + hi)
        elif abs(step) <= 8.9e-16 * (1.0 + abs(s)):
            # converged to about 4 ulps of 1 + |s|. (This was 1e-16, below one ulp near
            # s = 1: the loop then iterated until the bracket closed. Stopping earlier,
            # after any step below 1e-9, left a bias of a few ulps in the force that a
            # trajectory near a separatrix amplified past the 1e-9 of
            # tests/solvers/test_reference_states.py.)
            s = s_new
            break
        s = s_new
        if hi - lo <= 4.5e-16 * (1.0 + abs(s)):  # the bracket is down to an ulp or two
            break
    return j, s


@numba.njit(**JIT)
def bspline_value(par, x):
    j, s = bspline_locate(par, x)
    return cubic(par, V_OFFSET + 4 * j, s)


#: Within this distance outside [0, 1] forces follow the end pieces (so a stage that
#: overshoots a turning point sees the smooth continuation); farther out they are held
#: at their end values, so a coarse step that overshoots a steep wall is pushed back
#: instead of following an extrapolated cubic away.
OUTSIDE_MARGIN = 0.05


@numba.njit(**JIT)
def _guard(x):
    if x < -OUTSIDE_MARGIN:
        return 0.0
    if x > 1.0 + OUTSIDE_MARGIN:
        return 1.0
    return x


@numba.njit(**JIT)
def bspline_force(par, x):
    j, s = bspline_locate(par, _guard(x))
    return -dcubic(par, V_OFFSET + 4 * j, s) / dcubic(par, Q_OFFSET + 4 * j, s)


@numba.njit(**JIT)
def bspline_curvature(par, x):
    """d²V/dq² from the curve: (V'' q' - V' q'') / q'³ in the curve parameter."""
    j, s = bspline_locate(par, x)
    oq = Q_OFFSET + 4 * j
    ov = V_OFFSET + 4 * j
    dq = dcubic(par, oq, s)
    return (_d2cubic(par, ov, s) * dq - dcubic(par, ov, s) * _d2cubic(par, oq, s)) / dq**3


# ------------------------------------------------- piecewise cubics on a uniform q-grid


@numba.njit(**JIT)
def _grid_piece(par, x):
    n = par.shape[0] // 4
    u = x * n
    j = min(max(int(math.floor(u)), 0), n - 1)
    return 4 * j, u - j, n


@numba.njit(**JIT)
def grid_value(par, x):
    o, s, _ = _grid_piece(par, x)
    return cubic(par, o, s)


@numba.njit(**JIT)
def grid_force(par, x):
    o, s, n = _grid_piece(par, _guard(x))
    return -n * dcubic(par, o, s)


# ------------------------------------------------------------- vectorised evaluation


def _evaluate(pars, xs, out):
    for i in numba.prange(pars.shape[0]):
        for k in range(xs.shape[0]):
            out[i, k] = FN(pars[i], xs[k])


def evaluate(fn, pars, xs, out):
    """out[i, k] = fn(pars[i], xs[k]) for every potential i and point k."""
    specialised(_evaluate, {"FN": fn}, parallel=True)(pars, xs, out)


# ------------------------------------------------------- kernels specialised per function

_SPECIALISED = {}
_SOURCES = []


def _sources_hash():
    """A hash of this wing's sources (the force functions and the constants they use)."""
    if not _SOURCES:
        digest = hashlib.sha1()
        folder = os.path.dirname(os.path.abspath(__file__))
        try:
            for name in sorted(os.listdir(folder)):
                if name.endswith(".py"):
                    with open(os.path.join(folder, name), "rb") as f:
                        digest.update(name.encode() + b"\0" + f.read())
        except OSError:  # not a folder of files (a zip): the version stands in
            from .._version import __version__

            digest.update(__version__.encode())
        _SOURCES.append(digest)
    return _SOURCES[0].copy()


def specialised(template, functions, **options):
    """``template`` compiled with ``functions`` bound to its global names, cached on disk.

    A kernel that took ``force`` as an argument would be compiled again in every process
    (see ``JIT_FN_ARG``); its template instead calls ``FORCE(par, x)`` (or ``VALUE``,
    ``FN``, or the name of another template, bound to that template's copy), and each set
    of functions gets a compiled copy of its own, named after the template, the functions
    and a hash of their sources (so an edited force never reuses stale code: numba itself
    only checks the template's own file). Copies are made once per process and loaded
    from numba's cache after the first-ever compilation.

    A kernel that takes a function is inlined into a plain (not ``parallel``) copy, which
    the parallel copy then calls: inlined into a ``prange`` loop, it compiles twice as
    slowly (the parallel passes then work through its whole body).

    Args:
        template: a plain Python function whose body calls the names in ``functions``.
        functions: {global name: numba dispatcher}, e.g. ``{"FORCE": grid_force}``.
        **options: extra ``numba.njit`` options (``parallel=True``).

    Returns:
        the compiled (``cache=True``) dispatcher.

    Example:
        >>> import numpy as np
        >>> out = np.empty((1, 2))
        >>> kernel = specialised(_evaluate, {"FN": grid_value}, parallel=True)
        >>> kernel(np.arange(4.0)[None], np.array([0.0, 1.0]), out)
        >>> out.tolist()
        [[0.0, 6.0]]
    """
    key = (template, tuple(sorted(functions.items())), tuple(sorted(options.items())))
    kernel = _SPECIALISED.get(key)
    if kernel is None:
        digest = _sources_hash()
        digest.update(f"{template.__module__}.{template.__qualname__}".encode())
        names = []  # of the functions bound here or in the copies bound here
        for name, fn in key[1]:
            py = fn.py_func
            digest.update(f"|{name}={py.__module__}.{py.__qualname__}".encode())
            names += [n for n in getattr(fn, "_bound", [py.__qualname__]) if n not in names]
        copy = types.FunctionType(template.__code__, {**template.__globals__, **functions},
                                  template.__name__, template.__defaults__,
                                  template.__closure__)
        copy.__qualname__ = ".".join([template.__qualname__, *names, digest.hexdigest()[:12]])
        copy.__module__ = template.__module__
        copy.__doc__ = template.__doc__
        compiled: Any = numba.njit(**JIT, **options)(copy)
        compiled._bound = names  # read back above when this kernel is bound in turn
        kernel = compiled
        _SPECIALISED[key] = kernel
    return kernel
