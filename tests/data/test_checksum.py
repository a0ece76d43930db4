"""A dataset's checksum: what it covers, and one small draw's digest pinned from here on.

The checksum is a SHA-256 over the arrays only (names, shapes, dtypes, bytes); attributes
such as the package version do not enter it. The arrays' last bits do depend on the
OpenBLAS kernel that numpy picks for the CPU (the generator's Gaussian draw goes through
``np.linalg.cholesky``): the pinned digests are therefore taken in a child process with
``OPENBLAS_CORETYPE=Haswell``, a kernel every x86-64 CPU with AVX2 runs.
"""

import json
import os
import platform
import subprocess
import sys

import h5py
import numpy as np
import pytest

from nh_operators.data import generate_dataset
from nh_operators.data._h5 import checksum

#: generate_dataset(50, seed=1, ...) under OPENBLAS_CORETYPE=Haswell: Algorithm 1's
#: generator, and the reference code's (normalization="batch", as the paper-* presets).
PINNED = {
    "alg1": "sha256:b4cc374c773275ef5167e720c811c9b06843f93ed6e31e93d96b007497d25b8c",
    "paper": "sha256:40d1561be30cc5d580dd75085e69df7d93b0cd0f3ae7fa92af458248aa24075c",
}

_CHILD = """
import json, sys
from nh_operators.data import generate_dataset
out = {}
for name, kw in (("alg1", {}), ("paper", {"normalization": "batch"})):
    ds = generate_dataset(50, seed=1, path=f"{sys.argv[1]}/{name}.h5", progress=False, **kw)
    out[name] = ds.attrs["checksum"]
print(json.dumps(out))
"""


def _has_avx2() -> bool:
    if platform.machine().lower() not in ("x86_64", "amd64"):
        return False
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            return " avx2" in f.read()
    except OSError:
        return False


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


@pytest.mark.skipif(not _has_avx2(), reason="pins OpenBLAS's Haswell kernel (x86-64, AVX2)")
def test_small_draws_keep_their_pinned_checksums(tmp_path):
    env = {**os.environ, "OPENBLAS_CORETYPE": "Haswell", "OMP_NUM_THREADS": "1",
           "OPENBLAS_NUM_THREADS": "1"}
    res = subprocess.run([sys.executable, "-c", _CHILD, str(tmp_path)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    assert json.loads(res.stdout.strip().splitlines()[-1]) == PINNED
