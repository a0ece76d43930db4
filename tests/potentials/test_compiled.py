"""Formulas compiled to numba from the whitelisted tree (issue 14)."""

import numpy as np
import pytest

from nh_operators.potentials import PHYSICAL_POTENTIALS, parse_expression, parse_potential
from nh_operators.potentials.compiled import _emit, compile_expression, compiled_functions

FORMULAS = ["8*(q-0.5)**2", "2 - 3*sin(pi*q)**2 + 0.1*cos(5*q)*exp(-q)",
            "2*cosh(q-0.5)/cosh(0.5) + tanh(q) - tanh(1)*q", "4*abs(q-0.5) + 0*sign(q)",
            "2 - q*(1-q)*(3 + arctan(q) + sqrt(q+1) + log(q+2) + arcsin(q/2) - arccos(q/3))",
            "2 + sinh(q)*(q-1) - e**(-q)*q*(1-q)/tan(1 + q/4)"]


@pytest.mark.parametrize("text", FORMULAS)
def test_compiled_values_and_forces_match_numpy(text):
    expr = parse_expression(text)
    value, force = compile_expression(expr)
    q = np.linspace(-0.02, 1.02, 257)
    par = np.zeros(1)
    v = np.array([value(par, x) for x in q])
    f = np.array([force(par, x) for x in q])
    assert np.allclose(v, expr(q), rtol=1e-14, atol=1e-14)
    assert np.allclose(f, -expr.derivative(q), rtol=1e-13, atol=1e-13)


def test_physical_potentials_and_typed_formulas_are_compiled():
    for name in ("sho", "double_well", "morse", "mff"):
        value, force = compiled_functions(PHYSICAL_POTENTIALS[name])
        q = np.linspace(0, 1, 11)
        assert np.allclose([value(np.zeros(1), x) for x in q], PHYSICAL_POTENTIALS[name].V(q),
                           rtol=1e-14, atol=1e-14)
        assert np.allclose([-force(np.zeros(1), x) for x in q[1:-1] + 0.01],
                           PHYSICAL_POTENTIALS[name].dV(q[1:-1] + 0.01), rtol=1e-12, atol=1e-12)
    assert compiled_functions(parse_potential("8*(q-0.5)**2")) is not None


def test_smff_is_compiled_by_hand_with_the_same_series_branch():
    smff = PHYSICAL_POTENTIALS["smff"]
    value, force = compiled_functions(smff)
    edge = 0.1 / 20.0  # |u| = 0.1, where the series takes over
    q = np.concatenate([np.linspace(0, 1, 1001), 0.5 + np.linspace(-2 * edge, 2 * edge, 401),
                        0.5 + edge * np.array([1 - 1e-12, 1 + 1e-12, -1 + 1e-12, -1 - 1e-12]),
                        [0.5, -20.0, 30.0]])  # far outside: sinh² u would overflow
    par = np.zeros(1)
    # V = s·u coth u: no cancellation, each side within 4 ulps (a libm tanh and a few
    # rounded operations), so the two may differ by 8 ulps (1e-15 sat at rounding level)
    np.testing.assert_allclose([value(par, x) for x in q], smff.V(q),
                               rtol=8 * np.finfo(float).eps, atol=0)
    # the closed form of dV cancels for small |u| (see test_physical): the two math
    # libraries round that cancellation differently, by up to ~100 ulp there
    np.testing.assert_allclose([-force(par, x) for x in q], smff.dV(q), rtol=2e-13, atol=1e-18)


def test_generated_source_holds_only_our_strings_and_numbers():
    source = _emit(parse_expression("exp(-q)*2.5e-3 + pi")._tree)
    assert source == "(math.exp((-q)) * (0.0025)) + (3.141592653589793))".replace(
        "(math.exp", "((math.exp", 1)
    for bad in (("call", "__import__", ("var",)), ("attr", ("var",), ("var",))):
        with pytest.raises(ValueError, match="no compiled form"):
            _emit(bad)


def test_a_formula_and_smff_are_compiled_on_their_second_request_then_always():
    from nh_operators.potentials import compiled

    for potential in (parse_potential("2 - 5*q*(1-q)**2"), PHYSICAL_POTENTIALS["smff"]):
        key = "smff" if potential is PHYSICAL_POTENTIALS["smff"] else None
        compiled._USES.pop(key, None)
        assert compiled_functions(potential, after=1) is None  # a one-off stays in Python
        assert compiled_functions(potential, after=1) is not None
        assert compiled_functions(potential, after=0) is not None
        assert compiled_functions(potential, after=1) is not None  # never deferred again
    compiled._USES.pop("smff", None)
    assert compiled_functions(PHYSICAL_POTENTIALS["smff"], after=0) is not None
    assert compiled_functions(PHYSICAL_POTENTIALS["smff"], after=1) is not None  # compiled
