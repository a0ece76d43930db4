"""The envelope of the coarse starts: which orbits it lets in, on potentials built so
that each margin decides (released at rest at q = 0, where V(0) = V0 = 2)."""

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.solvers.rows import RowSource, row_source
from nh_operators.solvers.start_envelope import (BARRIER_MARGIN, INSIDE, KINETIC_MAX,
                                                 PAST_GUARD, TURNING_FORCE, inside_envelope,
                                                 orbit_flags, row_flags)

Q = nh.SENSORS


def double_well(a: float, m: float) -> np.ndarray:
    """A(2q−1)⁴ − B(2q−1)² + 2 − m with A − B = m: V(0) = V(1) = 2, a barrier at q = 1/2
    of height 2 − m (margin m below the energy), force 4(A + m) at release, min V
    2 − m − B²/(4A)."""
    x = 2.0 * Q - 1.0
    return a * x**4 - (a - m) * x**2 + 2.0 - m


def from_rest(*rows: np.ndarray) -> list[bool]:
    zero = np.zeros(len(rows))
    return inside_envelope(row_source(np.stack(rows), "sensors"), zero, zero).tolist()


def test_a_barrier_passed_slowly_is_outside_and_one_passed_fast_inside():
    assert from_rest(double_well(4.0, 0.5), double_well(4.0, 0.01)) == [True, False]
    assert 0.01 < BARRIER_MARGIN < 0.5


def test_a_release_where_the_force_almost_vanishes_is_outside():
    def tilted(tilt: float) -> np.ndarray:  # V(0) = V(1) = 2; force 2π·tilt at release
        return 1.0 + np.cos(2 * np.pi * Q) - tilt * np.sin(2 * np.pi * Q)

    assert from_rest(tilted(0.1), tilted(0.01)) == [True, False]
    assert 2 * np.pi * 0.01 < TURNING_FORCE < 2 * np.pi * 0.1


def test_too_fast_and_escaping_orbits_are_outside():
    deep = double_well(40.0, 1.0)  # min V = 1 − 39²/160 = −8.5: kinetic energy 10.5
    assert 2.0 - deep.min() > KINETIC_MAX
    assert from_rest(deep, 2.0 - 1.5 * Q) == [False, False]  # the slope leaves [0, 1]


def test_a_turn_at_a_flat_top_is_outside():
    """From the bottom of a well between tops at V = 2 (V = 2 − 1.5 sin²(2πq)), with
    energy 2 − m: the turn's slope falls like √m."""
    V = 2.0 - 1.5 * np.sin(2 * np.pi * Q) ** 2
    src = row_source(np.stack([V, V]), "sensors")
    q0 = np.full(2, 0.25)
    p0 = np.sqrt(2.0 * (2.0 - np.array([0.5, 1e-4]) - 0.5))
    assert inside_envelope(src, q0, p0).tolist() == [True, False]


def test_the_generator_is_inside_as_curves_and_as_sensors():
    space = nh.BoundedPotentialSpace(seed=77)
    pots = space.potentials(space.random(200))
    zero = np.zeros(200)
    assert inside_envelope(row_source(pots, "exact V"), zero, zero).all()
    assert inside_envelope(row_source(pots.V(Q), "sensors"), zero, zero).all()


def test_a_python_formula_gets_the_compiled_answer_without_a_compiler():
    V = double_well(4.0, 0.01)
    sensors = row_source(V[None], "sensors")
    python = RowSource(sensors.force.py_func, sensors.value.py_func, sensors.params, False)
    for q0, p0 in ((0.0, 0.0), (0.3, 1.0), (0.5, 0.05)):
        q, p = np.array([q0]), np.array([p0])
        assert inside_envelope(python, q, p) == inside_envelope(sensors, q, p)


@pytest.mark.parametrize("q0, p0, expected", [
    (0.25, 0.0, INSIDE),  # at rest at a wall's foot, force 4: turns at 0.75, slope 4
    (0.25, 1.0, INSIDE),  # E = 1: turns at 0.5 ± 0.354, both ways
    (0.25, 2.2, PAST_GUARD),  # E = 2.92 > V at the samples' ends (2.53): it leaves them
    (0.5, 0.0, 0),  # at rest at the bottom: no force, no motion to trust
    (0.5, 3.2, PAST_GUARD),  # E = 5.1: kinetic energy above KINETIC_MAX, and leaves
])
def test_the_samples_alone(q0: float, p0: float, expected: int):
    """On samples of V = 8(q − 1/2)² over [−1/16, 17/16]."""
    x = np.linspace(-0.0625, 1.0625, 289)
    v = 8.0 * (x - 0.5) ** 2
    v0, f0 = 8.0 * (q0 - 0.5) ** 2, -16.0 * (q0 - 0.5)
    assert orbit_flags(x, v, q0, p0, v0, f0) == expected
    assert orbit_flags.py_func(x, v, q0, p0, v0, f0) == expected


def test_an_orbit_past_the_guard_is_flagged():
    """Beyond OUTSIDE_MARGIN = 0.05 a sensor spline's force is held at its end value (a
    kink): released at rest at q = 0 on V = 2 + 0.5 q, the orbit runs out to the left;
    on the well it stays inside [0, 1]."""
    zero = np.zeros(2)
    flags = row_flags(row_source(np.stack([2.0 + 0.5 * Q, double_well(4.0, 0.5)]),
                                 "sensors"), zero, zero)
    assert flags.tolist() == [PAST_GUARD, INSIDE]


def test_a_callable_that_refuses_q_outside_the_domain_starts_resolved():
    """The samples reach 1/16 past [0, 1]; a callable that raises there, or warns, is not
    let in, and the solve neither fails nor warns because of the samples."""
    import warnings

    def force(_par, x):
        if not 0.0 <= x <= 1.0:
            raise ValueError("q outside [0, 1]")
        return -16.0 * (x - 0.5)

    def value(_par, x):
        if not 0.0 <= x <= 1.0:
            raise ValueError("q outside [0, 1]")
        return 8.0 * (x - 0.5) ** 2

    src = RowSource(force, value, np.zeros((1, 1)), False)
    assert row_flags(src, np.array([0.25]), np.zeros(1)).tolist() == [0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # nan below q = -0.01, where the samples reach and the orbit does not
        sol = nh.solve_classical("2 - 8*q*(1 - q)*sqrt(q + 0.01)", np.array([0.5, 1.5]),
                                 tol=1e-6)
    assert sol.error_estimate <= 1e-6
