"""Typed formulas compiled to numba: the solvers' kernels then run them like B-splines.

:func:`compile_expression` turns the whitelisted tree of
:func:`~nh_operators.potentials.expression.parse_expression` (and the tree of its exact
derivative) into two numba functions ``value(par, q)`` and ``force(par, q) = -V'(q)``,
with the signature of the spline kernels of :mod:`._spline_kernels`.

**No user text is ever executed.** The Python source handed to numba is generated from
the tree alone, and every piece of it comes from this module: the tree's node kinds map
to fixed operator strings and its function names to fixed entries of :data:`_CALLS`
(an unknown kind or name is a ``ValueError``, never text that is passed on); the only
values copied from the tree are numbers, written with ``repr(float(x))``, which is a
float literal (``inf`` and ``nan`` become ``math.inf`` and ``math.nan``). The tree was
built by the whitelist parser, which keeps no names, attributes or strings from the text.
"""

import functools
import hashlib
import math

import numba

from .expression import Expression, parse_expression
from .physical import MORSE_A, MORSE_DE, PHYSICAL_POTENTIALS, SMFF_ALPHA

__all__ = ["compile_expression", "compiled_functions"]


@numba.njit(nogil=True, cache=True)
def _sign(x):
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x  # 0.0, -0.0 or nan, like numpy.sign


_CALLS = {"sin": "math.sin", "cos": "math.cos", "tan": "math.tan", "exp": "math.exp",
          "log": "math.log", "sqrt": "math.sqrt", "abs": "abs", "sign": "_sign",
          "sinh": "math.sinh", "cosh": "math.cosh", "tanh": "math.tanh",
          "arctan": "math.atan", "arcsin": "math.asin", "arccos": "math.acos"}
_OPERATORS = {"add": "+", "sub": "-", "mul": "*", "div": "/", "pow": "**"}


def _number(value):
    value = float(value)
    if math.isnan(value):
        return "math.nan"
    if math.isinf(value):
        return "math.inf" if value > 0 else "(-math.inf)"
    return f"({value!r})"


def _emit(tree):
    """Python source of a tree, built only from this module's strings and float literals."""
    kind = tree[0]
    if kind == "const":
        return _number(tree[1])
    if kind == "var":
        return "q"
    if kind == "neg":
        return f"(-{_emit(tree[1])})"
    if kind == "call":
        if tree[1] not in _CALLS:
            raise ValueError(f"no compiled form of the function {tree[1]!r}")
        return f"{_CALLS[tree[1]]}({_emit(tree[2])})"
    if kind not in _OPERATORS:
        raise ValueError(f"no compiled form of the node {kind!r}")
    return f"({_emit(tree[1])} {_OPERATORS[kind]} {_emit(tree[2])})"


_COMPILED = {}


def _compile(value_source, force_source):
    if (value_source, force_source) not in _COMPILED:
        _COMPILED[value_source, force_source] = _build(value_source, force_source)
    return _COMPILED[value_source, force_source]


def _build(value_source, force_source):
    source = (f"def value(par, q):\n    return {value_source}\n\n"
              f"def force(par, q):\n    return -{force_source}\n")
    namespace = {"math": math, "_sign": _sign, "__name__": __name__}
    exec(compile(source, "<nh_operators compiled formula>", "exec"), namespace)  # noqa: S102
    # source generated at run time has no file for numba to cache it by: the kernels that
    # call a formula are cached instead (``_spline_kernels.specialised``), under names
    # that carry a hash of the formula's source
    tag = hashlib.sha1(source.encode()).hexdigest()[:16]
    jit = numba.njit(nogil=True, cache=False, error_model="numpy")
    functions = []
    for name in ("value", "force"):
        fn = namespace[name]
        fn.__qualname__ = f"formula_{tag}_{name}"
        functions.append(jit(fn))
    return tuple(functions)


def compile_expression(expr):
    """Compiled ``(value(par, q), force(par, q))`` of a parsed expression (cached).

    Args:
        expr: an :class:`~nh_operators.potentials.expression.Expression`.

    Returns:
        two numba functions of (par, q) -> float: V(q) and -dV/dq(q); ``par`` is unused.

    Example:
        >>> from nh_operators.potentials.expression import parse_expression
        >>> import numpy as np
        >>> value, force = compile_expression(parse_expression("8*(q-0.5)**2"))
        >>> value(np.zeros(1), 0.25), force(np.zeros(1), 0.25)
        (0.5, 4.0)
    """
    if not isinstance(expr, Expression):
        raise TypeError(f"expected a parsed Expression, got {type(expr).__name__}")
    return _compile(*_sources(expr))


def _sources(expr: Expression) -> tuple[str, str]:
    """The generated sources of V and V' of ``expr``, made once per expression (a solve
    asks for them on every call; emitting them again cost tens of µs)."""
    sources = expr.__dict__.get("_compiled_sources")
    if sources is None:
        sources = expr.__dict__["_compiled_sources"] = (_emit(expr._tree), _emit(expr._dtree))
    return sources


@functools.lru_cache(maxsize=None)
def _physical_expression(name: str) -> Expression:
    """The parsed formula of a physical potential (parsed once)."""
    return parse_expression(_PHYSICAL_FORMULAS[name])


#: The physical potentials that have a formula in the whitelist (SMFF evaluates a
#: removable singularity by series: its compiled form is written by hand below).
_PHYSICAL_FORMULAS = {
    "sho": "8*(q-0.5)**2",
    "double_well": "625/8*(q-0.2)**2*(q-0.8)**2",
    "mff": "4*abs(q-0.5)",
    "morse": f"{MORSE_DE!r}*(1-exp(-{MORSE_A!r}*(q-1/3)))**2",
}


#: Uses of each formula not compiled yet (see ``after``).
_USES = {}


def _deferred(key, after):
    """Whether this request of ``key`` stays uncompiled: its first ``after`` requests do,
    until one is compiled (then every later request is)."""
    seen = _USES.get(key, 0)
    if seen < after:
        _USES[key] = seen + 1
        return True
    _USES[key] = math.inf  # compiled from here on, whatever a later caller's ``after``
    return False


def _key(potential):
    expr = getattr(potential, "_V", None)
    if isinstance(expr, Expression):
        return expr
    name = getattr(potential, "name", None)
    if name in (*_PHYSICAL_FORMULAS, "smff") and PHYSICAL_POTENTIALS.get(name) is potential:
        return name
    return None


# SMFF, V = s u coth u with u = α (q - 1/2) and s = 4 tanh(α/2) / α, written by hand: the
# removable singularity at u = 0 takes the Taylor series of u coth u (as in
# :func:`~nh_operators.potentials.physical.smff`), which no whitelisted formula can say.
_SMFF_SCALE = 4.0 * math.tanh(SMFF_ALPHA / 2.0) / SMFF_ALPHA


@numba.njit(nogil=True, cache=True)
def _smff_value(par, q):
    u = SMFF_ALPHA * (q - 0.5)
    if abs(u) < 0.1:
        u2 = u * u
        return _SMFF_SCALE * (1 + u2 / 3 - u2**2 / 45 + 2 * u2**3 / 945 - u2**4 / 4725
                              + 2 * u2**5 / 93555)
    return _SMFF_SCALE * u / math.tanh(u)


@numba.njit(nogil=True, cache=True)
def _smff_force(par, q):
    u = SMFF_ALPHA * (q - 0.5)
    if abs(u) < 0.1:
        u2 = u * u
        d = u * (2 / 3 - 4 * u2 / 45 + 12 * u2**2 / 945 - 8 * u2**3 / 4725
                 + 20 * u2**4 / 93555)
    elif abs(u) > 350.0:  # sinh² would overflow; u / sinh² u is below 1e-300 there
        d = 1.0 / math.tanh(u)
    else:
        d = 1.0 / math.tanh(u) - u / math.sinh(u) ** 2
    return -_SMFF_SCALE * SMFF_ALPHA * d


def compiled_functions(potential, *, after=0):
    """Compiled (value, force) of a typed formula or a physical potential, else None.

    Compiling a formula, with the solver kernels specialised to it, takes 5–20 s the
    first time a formula is met on a machine (numba then caches the kernels on disk, and
    a later process loads them in about 0.1 s); a solve in Python takes 6–40 ms (near
    times). So the solvers ask with ``after=1``: a formula is compiled on its second
    solve in a process, and a one-off solve (the command line) stays in Python.

    Args:
        potential: what :func:`~nh_operators.potentials.as_potential` returns.
        after: return None for the first ``after`` requests of a formula not compiled
            yet.

    Returns:
        (value, force) numba functions, or None when the potential is only known as
        Python code (or is not compiled yet, see ``after``).

    Example:
        >>> from nh_operators.potentials import parse_potential
        >>> compiled_functions(parse_potential("8*(q-0.5)**2")) is not None
        True
    """
    key = _key(potential)
    if key is None:
        return None
    if key == "smff":
        return None if _deferred("smff", after) else (_smff_value, _smff_force)
    expr = key if isinstance(key, Expression) else _physical_expression(key)
    sources = _sources(expr)
    if sources not in _COMPILED and _deferred(sources, after):
        return None
    return compile_expression(expr)
