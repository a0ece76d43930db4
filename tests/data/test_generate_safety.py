"""No lost work, no silent corruption: locks, verified resumes, overwrites, bad files."""

import os
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from nh_operators.data import generate_dataset, load_dataset, partial_progress


def _interrupt_after(monkeypatch, chunks):
    import nh_operators.data.generate as generate_module

    calls = {"n": 0}
    original = generate_module.SampleSource.take

    def flaky(self, n, drops=None):
        calls["n"] += 1
        if calls["n"] > chunks:
            raise KeyboardInterrupt
        return original(self, n, drops)

    monkeypatch.setattr(generate_module.SampleSource, "take", flaky)
    return original


#: The first run of the lock test: the real CLI, whose labelling waits for a file to appear,
#: so that the second run certainly starts while the first holds the lock.
_PAUSED_RUN = """
import pathlib, sys, time
import nh_operators.data.generate as generate_module
take = generate_module.SampleSource.take
def paused(self, n, drops=None):
    while not pathlib.Path(sys.argv[1]).exists():
        time.sleep(0.02)
    return take(self, n, drops)
generate_module.SampleSource.take = paused
from nh_operators.cli import main
sys.exit(main(sys.argv[2:]))
"""
_CLI = "import sys; from nh_operators.cli import main; sys.exit(main(sys.argv[1:]))"


def test_two_runs_on_one_path_the_second_fails_at_once_and_the_first_finishes(tmp_path):
    out, go = tmp_path / "c.h5", tmp_path / "go"
    env = {**os.environ, "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
    args = ["generate", "--size", "200", "--chunk", "50", "--out", str(out), "--quiet"]
    first = subprocess.Popen([sys.executable, "-c", _PAUSED_RUN, str(go), *args, "--seed", "7"],
                             env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lock = tmp_path / "c.h5.lock"
    deadline = time.monotonic() + 120
    while not lock.exists() and first.poll() is None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert lock.exists(), first.communicate()
    second = subprocess.run([sys.executable, "-c", _CLI, *args, "--seed", "8"], env=env,
                            capture_output=True, text=True, timeout=120)
    go.touch()
    assert second.returncode == 2
    assert "Traceback" not in second.stderr and len(second.stderr.strip().splitlines()) == 1
    assert f"another process (pid {first.pid}) is writing {out}" in second.stderr
    _, err_first = first.communicate(timeout=120)
    assert first.returncode == 0, err_first
    ds = load_dataset(out)  # verifies the checksum
    assert len(ds) == 200 and ds.attrs["seed"] == 7
    np.testing.assert_array_equal(ds.q, generate_dataset(200, seed=7, progress=False).q)
    assert not lock.exists()


def test_resume_verifies_kept_chunks_and_relabels_a_modified_one(tmp_path, monkeypatch):
    clean = generate_dataset(60, seed=5, path=tmp_path / "clean.h5", chunk=20, progress=False)
    target = tmp_path / "r.h5"
    original = _interrupt_after(monkeypatch, chunks=2)
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(60, seed=5, path=target, chunk=20, progress=False)
    assert partial_progress(target) == (40, 60)
    with h5py.File(str(target) + ".partial", "r+") as f:  # a bit flipped on disk
        f["V"][25, 0] += 0.01
    import nh_operators.data.generate as generate_module

    monkeypatch.setattr(generate_module.SampleSource, "take", original)
    with pytest.warns(UserWarning, match=r"rows 20-39 no longer match the checksum recorded "
                                         r"when they were written; labelling them again "
                                         r"from row 20"):
        resumed = generate_dataset(60, seed=5, path=target, chunk=20, progress=False)
    assert resumed.attrs["checksum"] == clean.attrs["checksum"]
    np.testing.assert_array_equal(resumed.V, clean.V)


def test_resume_of_an_intact_partial_keeps_its_rows(tmp_path, monkeypatch):
    clean = generate_dataset(60, seed=5, progress=False)
    target = tmp_path / "r.h5"
    original = _interrupt_after(monkeypatch, chunks=2)
    with pytest.raises(KeyboardInterrupt):
        generate_dataset(60, seed=5, path=target, chunk=20, progress=False)
    import nh_operators.data.generate as generate_module

    calls = {"n": 0}

    def counting(self, n, drops=None):
        calls["n"] += 1
        return original(self, n, drops)

    monkeypatch.setattr(generate_module.SampleSource, "take", counting)
    resumed = generate_dataset(60, seed=5, path=target, chunk=20, progress=False)
    assert calls["n"] == 1  # only the last chunk was labelled again
    np.testing.assert_array_equal(resumed.q, clean.q)


def test_a_finished_file_is_replaced_only_with_force(tmp_path):
    out = tmp_path / "small.h5"
    first = generate_dataset(10, seed=1, path=out, progress=False)
    with pytest.raises(FileExistsError, match=r"already exists; pass force=True \(--force\)"):
        generate_dataset(12, seed=2, path=out, progress=False)
    assert load_dataset(out).attrs["checksum"] == first.attrs["checksum"]
    replaced = generate_dataset(12, seed=2, path=out, progress=False, force=True)
    assert len(replaced) == 12 and load_dataset(out).attrs["seed"] == 2


def test_output_paths_are_checked_before_any_work(tmp_path):
    with pytest.raises(ValueError, match="is a directory; give a file name"):
        generate_dataset(10, seed=1, path=tmp_path, progress=False)
    assert not list(tmp_path.parent.glob("*.partial"))
    with pytest.raises(FileNotFoundError, match="does not exist"):
        generate_dataset(10, seed=1, path=tmp_path / "no" / "x.h5", progress=False)
    with pytest.raises(ValueError, match="chunk must be a positive integer, got 0"):
        generate_dataset(10, seed=1, path=tmp_path / "x.h5", chunk=0, progress=False)
    with pytest.raises(ValueError, match="seed must be a non-negative integer, got -1"):
        generate_dataset(10, seed=-1, progress=False)


def test_a_read_only_folder_is_refused_up_front(tmp_path, monkeypatch):
    # (root writes into read-only folders, so the test asks os.access as a user would)
    real = os.access
    monkeypatch.setattr(os, "access", lambda path, mode: False if str(path) == str(tmp_path)
                        else real(path, mode))
    with pytest.raises(PermissionError, match=r"cannot write to .* \(read-only or no permission\)"):
        generate_dataset(10, seed=1, path=tmp_path / "x.h5", progress=False)
    assert not list(tmp_path.iterdir())


def test_truncated_and_directory_datasets_are_clear_errors(tmp_path):
    good = tmp_path / "good.h5"
    generate_dataset(10, seed=1, path=good, progress=False)
    cut = tmp_path / "cut.h5"
    cut.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    with pytest.raises(ValueError, match="not a readable HDF5 file .* it may be truncated"):
        load_dataset(cut)
    with pytest.raises(ValueError, match="is a directory; give the dataset's .h5 file"):
        load_dataset(tmp_path)
