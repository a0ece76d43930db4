"""What solve accepts as a potential: clear errors for what it cannot use, up front."""

import time

import numpy as np
import pytest

import nh_operators as nh
from nh_operators.potentials import as_potential, check_force


def test_names_are_case_insensitive():
    for name in ("SHO", "Sho", " double_WELL "):
        pot, info = as_potential(name)
        assert pot is nh.PHYSICAL_POTENTIALS[name.strip().lower()] and info == "exact V"
    assert nh.pretrained("DeepONet").name == "deeponet-alg1"


def test_a_singular_force_is_refused_up_front_and_names_the_wall():
    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"V'\(q\) is not finite at q = 0 \(V' = -inf\)"):
        nh.solve("2-(q*(1-q))**0.5", [0.5])
    assert time.perf_counter() - start < 2.0  # was 15.7 s, then NaN
    with pytest.raises(ValueError, match=r"not finite at q = 0.5"):  # a pole inside
        check_force(lambda q: 1.0 / (q - 0.5), "pole")
    with pytest.raises(ValueError, match="not finite at q = 1"):  # a callable, one wall
        nh.solve(lambda q: 2 - 8 * q * (1 - q) + 0 * np.sqrt(1 - q), [0.5],
                 dV=lambda q: 8 * (2 * q - 1) - 0.5 / np.sqrt(1 - q) * 0)


def test_sensor_values_of_the_wrong_shape_or_kind_say_so():
    V = 8 * (nh.SENSORS - 0.5) ** 2
    with pytest.raises(ValueError, match=r"must have shape \(100,\), one value per sensor "
                                         r"x_j = j/99; got shape \(99,\)"):
        nh.solve(V[:99], [0.5])
    with pytest.raises(ValueError, match="got 3 rows of sensor values; index one row"):
        nh.solve(np.stack([V, V, V]), [0.5])
    with pytest.raises(TypeError, match="complex"):
        nh.solve(V.astype(complex), [0.5])
    q = nh.solve(V, [0.5], tol=1e-8).q[0]
    assert abs(q - 0.5 * (1 - np.cos(2.0))) < 1e-5  # the spline of the SHO's sensors
