"""A process's first solve of a formula runs in Python and starts no numba compiler, with
the numbers the compiled kernels give."""

import subprocess
import sys

import numpy as np

from nh_operators.solvers._kernels import hermite, level_gap

# every numba dispatcher of the package that has compiled or loaded a signature
_PROBE = """
import sys, numba
import nh_operators as nh
sol = nh.solve("2 - 7*q*(1-q) + 0.5*q*q*(1-q)", [0.3, 1.1], tol=1e-8)
print(sol.method, sol.converged)
loaded = sorted(f"{name}.{attr}" for name, mod in list(sys.modules.items())
                if name.startswith("nh_operators") for attr, obj in vars(mod).items()
                if isinstance(obj, numba.core.registry.CPUDispatcher) and obj.signatures)
print(loaded)
"""


def test_first_formula_solve_loads_no_compiled_kernel():
    out = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out == ["rk4 True", "[]"]


def test_the_python_gap_is_the_compiled_gap_bit_for_bit():
    rng = np.random.default_rng(3)
    q, p, q2, p2 = (rng.normal(size=(5, 37)) for _ in range(4))
    for w in (np.full((1, 37), 1 / 37), rng.random((5, 37))):
        assert np.array_equal(level_gap(q, p, q2, p2, w), level_gap.py_func(q, p, q2, p2, w))
    # hermite is plain Python when called from Python: the cubic through its ends
    assert hermite(0.0, 0.1, 1.0, 2.0, 3.0, 4.0) == 1.0
    assert hermite(1.0, 0.1, 1.0, 2.0, 3.0, 4.0) == 3.0
    assert not hasattr(hermite, "signatures")
