"""The one sensor-spline helper (``nh_operators._sensors``): scipy's form, its constant
matrices and the compiled per-row kernel build the same not-a-knot spline, exact on
cubics; and the four users read it from there."""

import ast
from pathlib import Path

import numpy as np
import pytest

import nh_operators
from nh_operators._sensors import (
    notaknot_params,
    sensor_grid,
    sensor_spline,
    spline_coefficient_map,
    spline_matrix,
)

PACKAGE = Path(nh_operators.__file__).resolve().parent


def cubic(x):
    return 2 - 3 * x + 0.5 * x**2 - 4 * x**3


@pytest.mark.parametrize("m", [4, 7, 100])
def test_every_form_is_exact_on_a_cubic(m):
    x = sensor_grid(m)
    at = np.random.default_rng(0).uniform(0, 1, 50)
    spline = sensor_spline(cubic(x))
    np.testing.assert_allclose(spline(at), cubic(at), rtol=0, atol=1e-12)
    np.testing.assert_allclose(spline.derivative()(at), -3 + at - 12 * at**2, atol=1e-10)
    np.testing.assert_allclose(spline_matrix(at, m) @ cubic(x), cubic(at), atol=1e-12)
    # piece i of the coefficient map is the cubic about x_i: c3 = −4, c0 = cubic(x_i)
    c = (cubic(x) @ spline_coefficient_map(m)).reshape(m - 1, 4)
    np.testing.assert_allclose(c[:, 0], -4.0, atol=1e-9)
    np.testing.assert_allclose(c[:, 3], cubic(x[:-1]), atol=1e-13)


@pytest.mark.parametrize("m", [5, 100])
def test_the_compiled_kernel_is_the_same_spline_as_scipys(m):
    V = np.random.default_rng(1).normal(size=(6, m))
    out = np.empty((6, 4 * (m - 1)))
    notaknot_params(V, out)
    h = 1.0 / (m - 1)
    # kernel: a_j of s^j with s = (x − x_i)/h; scipy: c_k of (x − x_i)^(3 − k)
    scipy_c = (V @ spline_coefficient_map(m)).reshape(6, m - 1, 4)[..., ::-1]
    np.testing.assert_allclose(out.reshape(6, m - 1, 4), scipy_c * h ** np.arange(4),
                               rtol=0, atol=1e-11 * np.abs(V).max())


def test_the_grid_is_the_sensors_and_too_few_sensors_are_named():
    assert np.array_equal(sensor_grid(), nh_operators.SENSORS)
    with pytest.raises(ValueError, match="at least 4 sensors, got 3"):
        sensor_grid(3)


#: The modules that built the sensors' spline themselves before issue 40.
FORMER_BUILDERS = ["solvers/_kernels.py", "models/orbit_coordinates.py", "models/phase_rules.py",
                   "models/phaseonet.py", "evaluation/methods.py"]


@pytest.mark.parametrize("module", FORMER_BUILDERS)
def test_the_former_builders_read_the_helper(module):
    tree = ast.parse((PACKAGE / module).read_text())
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    assert "scipy.interpolate" not in imported


def test_the_solvers_kernel_is_the_helpers():
    from nh_operators.solvers import _kernels

    assert _kernels.notaknot_params is notaknot_params
