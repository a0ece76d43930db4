"""A dataset's checksum: what it covers, and small draws' digests pinned from here on.

The checksum is a SHA-256 over the arrays only (names, shapes, dtypes, bytes); attributes
such as the package version do not enter it. From draw 2 the generator's Gaussian draw
runs in plain loops (``nh_operators.potentials.gaussian``), so the pinned digests hold on
any x86-64 CPU: the child process below recomputes them with NumPy's AVX-512 code paths
switched off and another OpenBLAS kernel, as a CPU without AVX-512 would run (draw 1,
``np.exp`` and ``np.linalg.cholesky``, gave other bytes there). Measured, not pinned: a
CPU without FMA makes glibc's ``pow`` (the labels' step control) round differently, which
moves the labels, not the draw.
"""

import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

from nh_operators.data import generate_dataset, load_dataset, preset_kwargs
from nh_operators.data._h5 import checksum

#: ``nh-operators generate --preset paper-test --size 8`` (seed 42; 1,008 labelled
#: potentials from 6,250 candidates, the first 1,000 skipped), and
#: ``generate_dataset(50, seed=1, ...)`` of Algorithm 1's generator and of the
#: reference code's (normalization="batch"), all with draw 2.
PINNED = {
    "paper-test": "sha256:33cf12a7cab3dee1f62e47ea61dfda9106577799255dca942bca8f8c196a8730",
    "alg1": "sha256:06475dc9e88241de3075a6141d30b9f94e66e6dfde6fdeb923f890677094adc1",
    "paper": "sha256:e8887d0400f3721c2ef936efb181abf6ca60d1f007c2825c7eaa8bbd547da1bb",
}
CASES = {"paper-test": (8, 42, preset_kwargs("paper-test")), "alg1": (50, 1, {}),
         "paper": (50, 1, {"normalization": "batch"})}

_CHILD = """
import json, sys
from nh_operators.data import generate_dataset, preset_kwargs
cases = {"paper-test": (8, 42, preset_kwargs("paper-test")), "alg1": (50, 1, {}),
         "paper": (50, 1, {"normalization": "batch"})}
out = {name: generate_dataset(n, seed, f"{sys.argv[1]}/{name}.h5", progress=False,
                              **kw).attrs["checksum"] for name, (n, seed, kw) in cases.items()}
print(json.dumps(out))
"""


def _avx512_features() -> list[str]:
    """NumPy's SIMD extensions of AVX-512 found on this CPU (switched off in the child)."""
    found = np.show_config(mode="dicts")["SIMD Extensions"]["found"]
    return [f for f in found if f.startswith("AVX512") or f == "X86_V4"]


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    path = tmp_path_factory.mktemp("ck") / "small.h5"
    generate_dataset(20, seed=3, path=path, progress=False)
    return path


def test_checksum_covers_the_arrays_and_not_the_attributes(small):
    with h5py.File(small, "r+") as f:
        stored = f.attrs["checksum"]
        stored = stored.decode() if isinstance(stored, bytes) else stored
        assert checksum(f) == stored
        f.attrs["version"] = "99.0.0"  # another package version: same data, same checksum
        f.attrs["generator"] = json.dumps({"note": "attributes are not hashed"})
        assert checksum(f) == stored
        v = f["V"][3, 40]
        f["V"][3, 40] = np.nextafter(v, np.inf)  # one ulp in one sensor value
        assert checksum(f) != stored
        f["V"][3, 40] = v
        assert checksum(f) == stored


def test_the_paper_test_preset_keeps_its_pinned_checksum(tmp_path):
    n, seed, kw = CASES["paper-test"]
    first = generate_dataset(n, seed, tmp_path / "a.h5", progress=False, **kw)
    again = generate_dataset(n, seed, tmp_path / "b.h5", progress=False, **kw)
    assert first.attrs["checksum"] == again.attrs["checksum"] == PINNED["paper-test"]
    assert load_dataset(tmp_path / "a.h5").generator["draw"] == 2


@pytest.mark.parametrize("name", ["alg1", "paper"])
def test_small_draws_keep_their_pinned_checksums(tmp_path, name):
    n, seed, kw = CASES[name]
    assert generate_dataset(n, seed, tmp_path / "d.h5", progress=False,
                            **kw).attrs["checksum"] == PINNED[name]


def test_the_pins_hold_without_avx512_and_with_another_blas_kernel(tmp_path):
    env = {**os.environ, "OPENBLAS_CORETYPE": "Haswell", "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
    off = _avx512_features()
    if off:
        env["NPY_DISABLE_CPU_FEATURES"] = " ".join(off)
    res = subprocess.run([sys.executable, "-c", _CHILD, str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert json.loads(res.stdout.strip().splitlines()[-1]) == PINNED
