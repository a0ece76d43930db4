import numpy as np
import pytest

import nh_operators as nh
from nh_operators.potentials import FUNCTIONS, parse_expression, parse_potential

Q = np.linspace(0.01, 0.99, 56)  # even: no point on the kink of abs(q - 0.5)


def central_difference(f, q, h=1e-6):
    return (f(q + h) - f(q - h)) / (2 * h)


@pytest.mark.parametrize("text", [
    "8*(q-0.5)**2", "625/8*(q-0.2)**2*(q-0.8)**2", "4*abs(q-0.5)", "2**q - q/3",
    "exp(-q)*sin(3*q) + cos(q)**3", "sqrt(q + 1) - log(2 + q) + tanh(q) - sinh(q)/cosh(q)",
    "arctan(q) + arcsin(q/2) - arccos(q/3) + tan(q/2)", "-q + +q - -(q**-2) + pi*e",
    "q**q", "(1 + q)**0.5 / (2 - q)",
])
def test_values_and_exact_derivatives(text):
    f = parse_expression(text)
    namespace = {n: fn for n, (fn, _) in FUNCTIONS.items()} | {"pi": np.pi, "e": np.e}
    expected = eval(text, {"__builtins__": {}}, namespace | {"q": Q})  # the test's own oracle
    np.testing.assert_allclose(f(Q), expected, rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(f.derivative(Q), central_difference(f, Q), rtol=1e-6, atol=1e-7)


def test_sho_text_gives_the_physical_potential():
    pot = parse_potential("8*(q-0.5)**2")
    sho = nh.PHYSICAL_POTENTIALS["sho"]
    np.testing.assert_allclose(pot.V(Q), sho.V(Q), rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(pot.dV(Q), sho.dV(Q), rtol=1e-15, atol=1e-15)
    q, p = nh.integrate(pot, nh.TIMES, "rk4", 16)
    qe, pe = sho.exact(nh.TIMES)
    assert np.max(np.abs(q - qe)) < 1e-8 and np.max(np.abs(p - pe)) < 1e-7
    assert parse_expression("q**3").derivative_text == "(3 * (q ** 2))"


@pytest.mark.parametrize("text,match", [
    ("__import__('os').system('ls')", "not an allowed function"),
    ("q.real", "Attribute is not allowed"),
    ("[q][0]", "Subscript is not allowed"),
    ("lambda: 1", "Lambda is not allowed"),
    ("x + 1", "unknown name 'x'"),
    ("open('f')", "not an allowed function"),
    ("q if q else 1", "IfExp is not allowed"),
    ("q < 1", "Compare is not allowed"),
    ("'a'", "only real numbers"),
    ("1j*q", "only real numbers"),
    ("sin(q, 2)", "exactly one argument"),
    ("q^2", r"'\^' is not a power"),
    ("8*(q-0.5", "not a valid expression"),
    ("", "empty"),
    ("q" + "+q" * 600, "at most 1000"),
    ("q // 2", "BinOp is not allowed"),
])
def test_anything_else_is_a_clear_error(text, match):
    with pytest.raises(ValueError, match=match):
        parse_expression(text)


def test_bounded_conditions_are_checked():
    with pytest.raises(ValueError, match=r"V = 8\*q: V\(0\) = 0, but a bounded"):
        parse_potential("8*q")
    with pytest.raises(ValueError, match="V < V0"):
        parse_potential("2 + sin(pi*q)")


def test_power_tower_does_not_hang_and_overflows_to_inf():
    f = parse_expression("9**9**9**q")
    assert np.isinf(f(np.array([1.0])))[0]


@pytest.mark.parametrize("text,close", [("shoo", "'sho'"), ("double_wel", "'double_well'"),
                                        ("Morse2", "'morse'"), ("smf", "'smff' or 'mff'")])
def test_a_mistyped_physical_name_suggests_the_physical_names(text, close):
    physical = ", ".join(nh.PHYSICAL_POTENTIALS)
    for call in (lambda: nh.parse_potential(text), lambda: nh.solve(text, [0.5])):
        with pytest.raises(ValueError) as err:
            call()
        message = str(err.value)
        assert f"unknown name {text!r} (the variable is 'q'); did you mean {close}?" in message
        assert f"given by its name alone: {physical} (nh.PHYSICAL_POTENTIALS)" in message


def test_an_unknown_name_far_from_every_name_lists_the_physical_names_only():
    with pytest.raises(ValueError) as err:
        parse_expression("zzz * q")
    message = str(err.value)
    assert "unknown name 'zzz' (the variable is 'q'). A physical potential" in message
    assert "did you mean" not in message
