"""What the two test distributions cost the classical methods: Algorithm 1 against the paper's.

The paper's tables were made on its reference code's distribution (``paper-test``: the GRF
values of 6,250 candidates normalised together, the last 4,000 of 5,000 kept), not on
Algorithm 1 as printed (``alg1-test``: every potential normalised on its own). This script
generates both test sets (or reads them from ``--folder``), runs the classical baselines
on the sensors of each, and prints mean and median L_tot against the exact labels, with
the ratio between the distributions. It also prints the interior control values'
statistics of each set.

Run it with::

    python benchmarks/paper/distributions.py [--folder data] [--size 4000]

(``--size`` below 4,000 draws a smaller test set with the same recipe, for a quick look.)
"""

import argparse
import os
import time
import warnings

import numpy as np

from nh_operators.data import DATASET_PRESETS as PRESETS, generate_dataset, load_dataset, preset_kwargs
from nh_operators.evaluation import cpu_name, loss_per_sample
from nh_operators.solvers import ResolutionWarning, integrate, integrate_sensors, paper_rk4

#: (row name, run(V, potentials, t) -> (q, p)).
METHODS = [
    ("paper_rk4 (the paper's RK4 row, rebuilt)", lambda V, pots, t: paper_rk4(V, t)),
    ("rk4 on sensors, 1 substep", lambda V, pots, t: integrate_sensors(V, t, "rk4", 1)),
    ("rk4 on sensors, 4 substeps", lambda V, pots, t: integrate_sensors(V, t, "rk4", 4)),
    ("rk4 on sensors, 16 substeps", lambda V, pots, t: integrate_sensors(V, t, "rk4", 16)),
    ("yoshida8 on sensors, 2 substeps",
     lambda V, pots, t: integrate_sensors(V, t, "yoshida8", 2)),
    ("rk4 on the exact V, 4 substeps", lambda V, pots, t: integrate(pots, t, "rk4", 4)),
]


def test_set(name, folder, size):
    """The preset's test set, generated once into ``folder`` (a smaller one if asked)."""
    preset = PRESETS[name]
    kwargs = preset_kwargs(name)
    if size != preset["size"]:
        skip = kwargs.get("skip", 0) * size // preset["size"]
        kwargs = {**kwargs, "skip": skip} if "skip" in kwargs else kwargs
        if "pool" in kwargs:
            kwargs["pool"] = int(np.ceil(1.25 * (size + skip)))
    path = os.path.join(folder, f"{name}.h5" if size == preset["size"] else f"{name}-{size}.h5")
    if os.path.exists(path):
        return load_dataset(path)
    os.makedirs(folder, exist_ok=True)
    return generate_dataset(size, preset["seed"], path, progress=False, **kwargs)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--folder", default="data", help="where the test sets are kept")
    parser.add_argument("--size", type=int, default=4000, help="potentials per test set")
    args = parser.parse_args()
    sets = {}
    for name in ("alg1-test", "paper-test"):
        start = time.perf_counter()
        sets[name] = test_set(name, args.folder, args.size)
        values = sets[name].control_V[:, 1:-1]
        values = values[np.isfinite(values)]
        values = values[values < 2.0 - 1e-12]  # the end points of short rows are NaN-padded
        print(f"{name}: {len(sets[name])} potentials, checksum {sets[name].attrs['checksum'][:19]}…,"
              f" interior control values mean {values.mean():.3f}, std {values.std():.3f}"
              f" ({time.perf_counter() - start:.1f} s)")
    print(f"\nmean (median) L_tot against the exact labels; {cpu_name()}\n")
    print("| method | Algorithm 1 (alg1-test) | paper's data (paper-test) | ratio of means |")
    print("|---|---:|---:|---:|")
    for label, run in METHODS:
        cells = []
        for ds in sets.values():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ResolutionWarning)
                q, p = run(ds.V, ds.potentials(), ds.t)
            loss = loss_per_sample(q, p, ds.q, ds.p)["L_tot"]
            cells.append((float(np.mean(loss)), float(np.median(loss))))
        print(f"| {label} | {cells[0][0]:.2e} ({cells[0][1]:.1e}) | {cells[1][0]:.2e} "
              f"({cells[1][1]:.1e}) | {cells[0][0] / cells[1][0]:.0f}× |")


if __name__ == "__main__":
    main()
