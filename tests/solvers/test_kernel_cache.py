"""Compiled kernels are cached on disk: a second process loads them and compiles nothing.

Each check runs fresh Python processes on one empty ``NUMBA_CACHE_DIR`` and reads numba's
own bookkeeping (compile events, the dispatchers' cache hits and misses), not timings.
"""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from nh_operators.potentials import _spline_kernels
from nh_operators.potentials._spline_kernels import _evaluate, grid_force, grid_value, specialised

# Prints, as JSON, the nh_operators functions numba compiled and the specialised kernels'
# cache hits and misses after the code that follows it.
PROBE = """
import json, sys
from numba.core import event

compiled = []


class Listener(event.Listener):
    def on_start(self, e):
        pass

    def on_end(self, e):
        f = e.data["dispatcher"].py_func
        compiled.append(f"{f.__module__}.{f.__qualname__}")


event.register("numba:compile", Listener())
import numpy as np
import nh_operators as nh
from nh_operators.potentials import _spline_kernels
"""
REPORT = """
inner = {id(f) for key in _spline_kernels._SPECIALISED for _, f in key[1]}
kernels = {d.py_func.__qualname__: [sum(d.stats.cache_hits.values()),
                                    sum(d.stats.cache_misses.values()), id(d) in inner]
           for d in _spline_kernels._SPECIALISED.values()}
print(json.dumps({"compiled": [c for c in compiled if c.startswith("nh_operators")],
                  "kernels": kernels}))
"""


def _run(code, cache):
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "OMP_NUM_THREADS": "1",
           "NUMBA_NUM_THREADS": "1"}
    res = subprocess.run([sys.executable, "-c", PROBE + code + REPORT], env=env,
                         capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout.strip().splitlines()[-1])


def _check_second_process_compiles_nothing(code, cache):
    first = _run(code, cache)
    assert first["kernels"] and all(miss >= 1 for _, miss, _ in first["kernels"].values())
    names = [n for _, _, files in os.walk(cache) for n in files]
    for kernel in first["kernels"]:  # an index and a data file per specialised kernel
        assert any(n.endswith(".nbi") and f".{kernel}-" in n for n in names), kernel
        assert any(n.endswith(".nbc") and f".{kernel}-" in n for n in names), kernel
    second = _run(code, cache)
    assert second["compiled"] == []
    assert second["kernels"].keys() == first["kernels"].keys()
    # loaded, never compiled; a kernel that only others call (one row of the steppers)
    # is not even loaded: its code is part of theirs
    assert all(miss == 0 and (hit >= 1 or inner) for hit, miss, inner in
               second["kernels"].values())
    return first


def test_specialised_kernels_load_from_the_cache_in_a_new_process(tmp_path):
    code = """
from nh_operators.solvers import _rowwise
from nh_operators.potentials.compiled import compile_expression
from nh_operators.potentials.expression import parse_expression

x = np.linspace(0, 1, 5)[None]
out = np.empty_like(x)
_rowwise.rowwise(_spline_kernels.grid_force, np.arange(8.0)[None], x, out)
value, _ = compile_expression(parse_expression("2 - 5*q*(1-q)**2"))
_rowwise.rowwise(value, np.zeros((1, 1)), x, out)
"""
    first = _check_second_process_compiles_nothing(code, tmp_path)
    assert len(first["kernels"]) == 2  # one per function: grid_force, the formula's V


@pytest.mark.slow
def test_first_answers_compile_nothing_in_a_second_process(tmp_path):
    """Sensors, a B-spline (with a far time: the period's kernels) and a formula (its
    second solve is compiled), and many rows on their own grids."""
    code = """
V = 8 * (np.linspace(0, 1, 100) - 0.5) ** 2
nh.solve(V, [0.5], tol=1e-6, method="classical")
nh.solve_many(np.stack([V, 0.5 * V + 1.0]), np.array([[0.5, 1.0], [0.25, 2.0]]), tol=1e-6,
              method="classical")
space = nh.BoundedPotentialSpace(seed=0)
nh.solve(space.potentials(space.random(1))[0], [0.5, 30.0], tol=1e-6, method="classical")
for _ in range(2):
    nh.solve("2 - 5*q*(1-q)**2", [0.5], tol=1e-6, method="classical")
"""
    first = _check_second_process_compiles_nothing(code, tmp_path)
    # a formula's second solve: one row, all its levels in the compiled doubling
    assert any(k.startswith("_doubling_template.formula_") for k in first["kernels"])
    assert any(k.startswith("_batch_orbit_period.bspline_force") for k in first["kernels"])


def test_one_specialisation_per_function_named_after_it():
    a = specialised(_evaluate, {"FN": grid_value}, parallel=True)
    assert specialised(_evaluate, {"FN": grid_value}, parallel=True) is a
    b = specialised(_evaluate, {"FN": grid_force}, parallel=True)
    assert b is not a
    assert a.py_func.__qualname__.startswith("_evaluate.grid_value.")
    assert b.py_func.__qualname__.startswith("_evaluate.grid_force.")
    assert a.py_func.__code__ is _evaluate.__code__  # the template's own code, not a copy
    out, ref = np.empty((2, 3)), np.empty((2, 3))
    pars, x = np.arange(16.0).reshape(2, 8), np.array([0.1, 0.5, 0.9])
    a(pars, x, out)
    _spline_kernels.evaluate(grid_value, pars, x, ref)
    np.testing.assert_array_equal(out, ref)
    np.testing.assert_array_equal(out[1], [grid_value.py_func(pars[1], xi) for xi in x])
