"""Potentials typed as text, parsed safely: ``parse_potential("8*(q-0.5)**2")``.

The text is parsed with :mod:`ast` into a small tree of our own and evaluated with NumPy;
nothing is ever passed to ``eval``. Allowed: numbers, the variable ``q``, the constants
``pi`` and ``e``, ``+ - * / **`` and unary minus, parentheses, and the functions in
:data:`FUNCTIONS`. Anything else (attributes, subscripts, other names, keywords,
comparisons, lambdas, ...) is a ``ValueError`` that names the offending piece. The
derivative dV/dq is the exact symbolic derivative of the same tree.
"""

import ast
import difflib
import math
from typing import NoReturn

import numpy as np

from .physical import PHYSICAL_POTENTIALS

__all__ = ["FUNCTIONS", "parse_potential", "parse_expression"]

MAX_LENGTH = 1000

#: name -> (NumPy function, derivative as a function of the argument's tree).
FUNCTIONS = {
    "sin": (np.sin, lambda a: ("call", "cos", a)),
    "cos": (np.cos, lambda a: ("neg", ("call", "sin", a))),
    "tan": (np.tan, lambda a: ("div", ("const", 1.0), ("pow", ("call", "cos", a), ("const", 2.0)))),
    "exp": (np.exp, lambda a: ("call", "exp", a)),
    "log": (np.log, lambda a: ("div", ("const", 1.0), a)),
    "sqrt": (np.sqrt, lambda a: ("div", ("const", 0.5), ("call", "sqrt", a))),
    "abs": (np.abs, lambda a: ("call", "sign", a)),
    "sign": (np.sign, lambda a: ("const", 0.0)),
    "sinh": (np.sinh, lambda a: ("call", "cosh", a)),
    "cosh": (np.cosh, lambda a: ("call", "sinh", a)),
    "tanh": (np.tanh, lambda a: ("sub", ("const", 1.0),
                                 ("pow", ("call", "tanh", a), ("const", 2.0)))),
    "arctan": (np.arctan, lambda a: ("div", ("const", 1.0),
                                     ("add", ("const", 1.0), ("pow", a, ("const", 2.0))))),
    "arcsin": (np.arcsin, lambda a: ("div", ("const", 1.0), ("call", "sqrt", (
        "sub", ("const", 1.0), ("pow", a, ("const", 2.0)))))),
    "arccos": (np.arccos, lambda a: ("neg", ("div", ("const", 1.0), ("call", "sqrt", (
        "sub", ("const", 1.0), ("pow", a, ("const", 2.0))))))),
}
CONSTANTS = {"pi": math.pi, "e": math.e}

#: Functions whose derivative jumps or vanishes on a set: a potential using them is not C².
NON_SMOOTH = frozenset({"abs", "sign"})


def _uses(tree, names):
    """Whether the tree calls any function in ``names``."""
    if not isinstance(tree, tuple):
        return False
    if tree[0] == "call" and tree[1] in names:
        return True
    return any(_uses(part, names) for part in tree[1:])
_BINARY = {ast.Add: "add", ast.Sub: "sub", ast.Mult: "mul", ast.Div: "div", ast.Pow: "pow"}
_SYMBOL = {"add": "+", "sub": "-", "mul": "*", "div": "/", "pow": "**"}


def _fail(text: str, node: ast.AST, why: str) -> NoReturn:
    col = getattr(node, "col_offset", None)
    where = f" at column {col + 1}" if col is not None else ""
    raise ValueError(f"cannot use {ast.get_source_segment(text, node) or why!r} in a "
                     f"potential{where}: {why}. Allowed: numbers, q, pi, e, + - * / **, "
                     f"parentheses and {', '.join(sorted(FUNCTIONS))}")


def _unknown_name(name: str, variable: str) -> str:
    """Why ``name`` is refused, with close matches and the physical potentials' names.

    Example:
        >>> _unknown_name("shoo", "q").split("?")[0]
        "unknown name 'shoo' (the variable is 'q'); did you mean 'sho'"
    """
    known = [variable, *CONSTANTS, *FUNCTIONS, *PHYSICAL_POTENTIALS]
    close = difflib.get_close_matches(name.lower(), known, n=3, cutoff=0.6)
    hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else "."
    return (f"unknown name {name!r} (the variable is {variable!r}){hint} A physical "
            f"potential is given by its name alone: {', '.join(PHYSICAL_POTENTIALS)} "
            "(nh.PHYSICAL_POTENTIALS)")


def _tree(node, text, variable):
    """ast node -> our tree of tuples, refusing everything not on the whitelist."""
    if isinstance(node, ast.Expression):
        return _tree(node.body, text, variable)
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            _fail(text, node, "only real numbers are allowed as constants")
        return ("const", float(node.value))
    if isinstance(node, ast.Name):
        if node.id == variable:
            return ("var",)
        if node.id in CONSTANTS:
            return ("const", CONSTANTS[node.id])
        _fail(text, node, _unknown_name(node.id, variable))
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return (_BINARY[type(node.op)], _tree(node.left, text, variable),
                _tree(node.right, text, variable))
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        inner = _tree(node.operand, text, variable)
        return ("neg", inner) if isinstance(node.op, ast.USub) else inner
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            _fail(text, node.func, "not an allowed function")
        if len(node.args) != 1 or node.keywords:
            _fail(text, node, f"{node.func.id} takes exactly one argument")
        return ("call", node.func.id, _tree(node.args[0], text, variable))
    _fail(text, node, f"{type(node).__name__} is not allowed")


def _evaluate(tree, q):
    kind = tree[0]
    if kind == "const":
        return np.full_like(q, tree[1])
    if kind == "var":
        return q
    if kind == "neg":
        return -_evaluate(tree[1], q)
    if kind == "call":
        return FUNCTIONS[tree[1]][0](_evaluate(tree[2], q))
    a, b = _evaluate(tree[1], q), _evaluate(tree[2], q)
    if kind == "add":
        return a + b
    if kind == "sub":
        return a - b
    if kind == "mul":
        return a * b
    if kind == "div":
        return a / b
    return np.power(a, b)


def _is_const(tree, value=None):
    return tree[0] == "const" and (value is None or tree[1] == value)


def _simplify(tree):
    """Fold the zeros and ones that differentiation leaves behind (keeps trees small)."""
    kind = tree[0]
    if kind in ("const", "var"):
        return tree
    if kind == "neg":
        inner = _simplify(tree[1])
        return ("const", -inner[1]) if _is_const(inner) else ("neg", inner)
    if kind == "call":
        return ("call", tree[1], _simplify(tree[2]))
    a, b = _simplify(tree[1]), _simplify(tree[2])
    if kind == "add" and _is_const(a, 0.0):
        return b
    if kind in ("add", "sub") and _is_const(b, 0.0):
        return a
    if kind == "sub" and _is_const(a, 0.0):
        return ("neg", b)
    if kind == "mul" and (_is_const(a, 0.0) or _is_const(b, 0.0)):
        return ("const", 0.0)
    if kind == "mul" and _is_const(a, 1.0):
        return b
    if kind in ("mul", "div") and _is_const(b, 1.0):
        return a
    if kind == "div" and _is_const(a, 0.0):
        return ("const", 0.0)
    return (kind, a, b)


def _derivative(tree):
    kind = tree[0]
    if kind == "const":
        return ("const", 0.0)
    if kind == "var":
        return ("const", 1.0)
    if kind == "neg":
        return ("neg", _derivative(tree[1]))
    if kind == "call":
        return ("mul", FUNCTIONS[tree[1]][1](tree[2]), _derivative(tree[2]))
    a, b = tree[1], tree[2]
    da, db = _derivative(a), _derivative(b)
    if kind in ("add", "sub"):
        return (kind, da, db)
    if kind == "mul":
        return ("add", ("mul", da, b), ("mul", a, db))
    if kind == "div":
        return ("div", ("sub", ("mul", da, b), ("mul", a, db)), ("pow", b, ("const", 2.0)))
    if _is_const(b):  # a**c: c a**(c-1) a'
        return ("mul", ("mul", b, ("pow", a, ("const", b[1] - 1.0))), da)
    # a**b = exp(b log a): a**b (b' log a + b a'/a)
    return ("mul", tree, ("add", ("mul", db, ("call", "log", a)), ("div", ("mul", b, da), a)))


def _format(tree):
    kind = tree[0]
    if kind == "const":
        return f"{tree[1]:g}"
    if kind == "var":
        return "q"
    if kind == "neg":
        return f"-({_format(tree[1])})"
    if kind == "call":
        return f"{tree[1]}({_format(tree[2])})"
    return f"({_format(tree[1])} {_SYMBOL[kind]} {_format(tree[2])})"


class Expression:
    """A parsed expression in one variable with its exact derivative (final).

    Attributes:
        text: the text as given.
        derivative_text: dV/dq, written out.
        smooth: False where the text uses ``abs`` or ``sign`` (a kink or a jump: the
            classical solver's step-doubling estimate then gets no credit for the
            method's order).
    """

    def __init__(self, text, tree):
        self.text = text
        self._tree = tree
        self.smooth = not _uses(tree, NON_SMOOTH)
        self._dtree = _simplify(_derivative(tree))
        self.derivative_text = _format(self._dtree)

    def __call__(self, q):
        """Values at q (any shape), float64."""
        q = np.asarray(q, dtype=np.float64)
        with np.errstate(all="ignore"):
            return _evaluate(self._tree, q)

    def derivative(self, q):
        """Exact d/dq at q (any shape), float64."""
        q = np.asarray(q, dtype=np.float64)
        with np.errstate(all="ignore"):
            return _evaluate(self._dtree, q)

    def __repr__(self):
        return f"Expression({self.text!r})"


def parse_expression(text, variable="q"):
    """Parse text into an :class:`Expression`, never evaluating it as code.

    Args:
        text: e.g. ``"8*(q-0.5)**2"`` (``^`` is not a power: write ``**``).
        variable: the name of the variable.

    Returns:
        :class:`Expression`.

    Raises:
        ValueError: for a syntax error or anything outside the whitelist, naming it.

    Example:
        >>> f = parse_expression("8*(q-0.5)**2")
        >>> float(f(0.0)), float(f.derivative(0.0))
        (2.0, -8.0)
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError("the potential is empty: give an expression in q, e.g. 8*(q-0.5)**2")
    if len(text) > MAX_LENGTH:
        raise ValueError(f"the expression is {len(text)} characters long; at most "
                         f"{MAX_LENGTH} are accepted")
    if "^" in text:
        raise ValueError(f"{text!r}: '^' is not a power here; write q**2 for q squared")
    try:
        node = ast.parse(text.strip(), mode="eval")
    except SyntaxError as err:
        raise ValueError(f"{text!r} is not a valid expression: {err.msg} at column "
                         f"{err.offset}") from None
    return Expression(text, _tree(node, text.strip(), variable))


def parse_potential(text, *, name=None):
    """A potential from text, checked against the bounded conditions.

    Args:
        text: an expression in ``q`` (see :func:`parse_expression`).
        name: the potential's name in tables (default: the text).

    Returns:
        :class:`~nh_operators.AnalyticPotential` with exact ``V`` and ``dV``.

    Raises:
        ValueError: if the text is not allowed, or V breaks the bounded conditions
            (V(0) = V(1) = 2, V < 2 inside; named by :func:`~nh_operators.check_bounded`).

    Example:
        >>> pot = parse_potential("8*(q-0.5)**2")
        >>> float(pot.dV(0.25))
        -4.0
    """
    from .bounded import check_bounded
    from .physical import AnalyticPotential

    expr = parse_expression(text)
    check_bounded(expr, name=f"V = {text}: V")
    return AnalyticPotential(name or text, text, expr, expr.derivative, smooth=expr.smooth)
