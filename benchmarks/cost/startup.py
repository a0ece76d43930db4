"""Start-up cost: fresh processes that import the package, print --help, or give a first answer.

Each case runs ``--repeats`` times in a new Python process and the tables give the median
wall time of the whole process (timings on a shared machine are noisy: compare medians).

- The first table: import, ``--help`` and a classical ``nh.solve``, with numba's cache
  wherever it is (``NUMBA_CACHE_DIR`` or the package's ``__pycache__``), plus which heavy
  libraries the process ended up loading.
- The second table: the first answer of a process (the ``predict`` command with a
  formula, the first ``nh.solve`` on 100 sensor values, on a B-spline potential and on a
  formula), **cold** (``NUMBA_CACHE_DIR`` an empty temporary folder: every numba kernel
  compiles, as on the first-ever run on a machine) and **warm** (the same folder after one
  run: what every later process pays).

Run it on two checkouts (for example before and after a change) to compare them; the
processes import ``nh_operators`` from the current folder first, then ``PYTHONPATH``::

    OMP_NUM_THREADS=1 NUMBA_NUM_THREADS=1 python benchmarks/cost/startup.py --repeats 3
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

HEAVY = ("torch", "deepxde", "numba", "matplotlib")
CASES = {
    "import nh_operators": "import nh_operators",
    "nh-operators --help": ("from nh_operators.cli import main\ntry:\n    main(['--help'])\n"
                            "except SystemExit:  # an older main lets argparse exit\n    pass"),
    "classical nh.solve": "import nh_operators as nh; nh.solve('sho', [0.5], tol=1e-8)",
}
PREDICT = ["predict", "--potential", "8*(q-0.5)**2", "--times", "0.5", "1", "--tol", "1e-6"]
#: First answers: Python code, or a list of ``python -m nh_operators`` arguments.
FIRST = {
    "nh-operators " + " ".join(repr(a) if "*" in a else a for a in PREDICT): PREDICT,
    "nh.solve on 100 sensor values": (
        "import numpy as np, nh_operators as nh\n"
        "V = 8 * (np.linspace(0, 1, 100) - 0.5) ** 2\n"
        "nh.solve(V, [0.5], tol=1e-6)"),
    "nh.solve on a B-spline potential": (
        "import nh_operators as nh\n"
        "space = nh.BoundedPotentialSpace(seed=0)\n"
        "nh.solve(space.potentials(space.random(1))[0], [0.5], tol=1e-6)"),
    # the same without the space, which subclasses DeepXDE's and so imports torch
    "nh.solve on a B-spline from control points": (
        "import nh_operators as nh\n"
        "nh.solve(nh.BoundedPotential([0, 0.3, 0.7, 1], [2, -1, 0.5, 2]), [0.5], tol=1e-6)"),
    "nh.solve on a formula": "import nh_operators as nh; nh.solve('8*(q-0.5)**2', [0.5], tol=1e-6)",
    # the floor of any answer that runs a numba kernel: NumPy, numba, one cached kernel
    "numba alone: one cached kernel": (
        "import numpy as np, numba\n"
        "from nh_operators.solvers import _kernels\n"
        "_kernels.notaknot_params(np.zeros((1, 100)), np.empty((1, 396)))"),
}


def run(code, env=None):
    """Wall time of a fresh process running ``code``, and the heavy libraries it loaded."""
    if isinstance(code, list):  # the command line
        argv = [sys.executable, "-m", "nh_operators", *code]
    else:
        probe = (f"{code}\nimport sys; print(*[m for m in {HEAVY!r} if m in sys.modules], "
                 "file=sys.stderr)")
        argv = [sys.executable, "-c", probe]
    start = time.perf_counter()
    res = subprocess.run(argv, capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - start
    if res.returncode:
        raise RuntimeError(res.stderr)
    lines = res.stderr.strip().splitlines()
    return seconds, lines[-1] if lines and not isinstance(code, list) else ""


def first_answer(code, repeats):
    """Median seconds of ``code`` with an empty numba cache (cold) and a primed one (warm)."""
    cold, warm = [], []
    with tempfile.TemporaryDirectory() as shared:
        env = {**os.environ, "NUMBA_CACHE_DIR": shared}
        run(code, env)  # primes ``shared``
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as empty:
                cold.append(run(code, {**os.environ, "NUMBA_CACHE_DIR": empty})[0])
            warm.append(run(code, env)[0])
    return statistics.median(cold), statistics.median(warm)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--only", choices=("startup", "first"), help="one table only")
    args = parser.parse_args()
    if args.only != "first":
        print("| case | median wall time (s) | heavy libraries loaded |\n|---|---:|---|")
        for label, code in CASES.items():
            results = [run(code) for _ in range(args.repeats)]
            print(f"| {label} | {statistics.median(r[0] for r in results):.2f} | "
                  f"{results[-1][1] or 'none'} |")
    if args.only != "startup":
        if args.only is None:
            print()
        print(f"| first answer of a process | cold cache (s) | warm cache (s) |\n"
              "|---|---:|---:|")
        for label, code in FIRST.items():
            cold, warm = first_answer(code, args.repeats)
            print(f"| {label} | {cold:.2f} | {warm:.2f} |", flush=True)


if __name__ == "__main__":
    main()
