"""Start-up cost: fresh processes that import the package, print --help, or solve classically.

Each case runs ``--repeats`` times in a new Python process; the table gives the median wall
time and which heavy libraries the process ended up loading. Run it on two checkouts (for
example before and after a change) to compare them::

    python benchmarks/startup.py [--repeats 5]
"""

import argparse
import statistics
import subprocess
import sys
import time

HEAVY = ("torch", "deepxde", "numba", "matplotlib")
CASES = {
    "import nh_operators": "import nh_operators",
    "nh-operators --help": ("from nh_operators.cli import main\ntry:\n    main(['--help'])\n"
                            "except SystemExit:  # an older main lets argparse exit\n    pass"),
    "classical nh.solve": "import nh_operators as nh; nh.solve('sho', [0.5], tol=1e-8)",
}


def run(code):
    probe = f"{code}\nimport sys; print(*[m for m in {HEAVY!r} if m in sys.modules], file=sys.stderr)"
    start = time.perf_counter()
    res = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if res.returncode:
        raise RuntimeError(res.stderr)
    return seconds, res.stderr.strip().splitlines()[-1] if res.stderr.strip() else ""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    print("| case | median wall time (s) | heavy libraries loaded |\n|---|---:|---|")
    for label, code in CASES.items():
        results = [run(code) for _ in range(args.repeats)]
        print(f"| {label} | {statistics.median(r[0] for r in results):.2f} | "
              f"{results[-1][1] or 'none'} |")


if __name__ == "__main__":
    main()
