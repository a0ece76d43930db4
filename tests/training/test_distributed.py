"""Data-parallel training under torchrun: two gloo processes against one, rank death.

Each torchrun launch starts two Python processes that import torch and DeepXDE (about
10 s on a busy 2-core machine); the data is tiny (56 potentials, a TraONet of 5,666
parameters, float64).
"""

import os
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from model_helpers import TINY

import nh_operators as nh
from nh_operators.data import generate_dataset
from nh_operators.training import Distributed, RankFailed, load_checkpoint
from nh_operators.training import trainer as trainer_module
from nh_operators.training.distributed import FAIL_ENV

ARCH = TINY["traonet"]
EPOCHS, SEED, BATCH = 2, 7, 10  # 45 training rows: 4 batches of 10 and one of 5 (2 + 3)


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def torchrun(data, out, *extra, env=None, nproc=2):
    """``torchrun --nproc_per_node nproc nh-operators train ...``; the finished process."""
    bindir = Path(sys.executable).parent
    command = [sys.executable, "-m", "torch.distributed.run", "--nproc_per_node",
               str(nproc), "--master-addr", "127.0.0.1", "--master-port",
               str(_free_port()), "--monitor-interval", "1", "--no-python",
               str(bindir / "nh-operators"), "train", "--model", "traonet", "--data",
               str(data), "--out", str(out), "--epochs", str(EPOCHS), "--seed", str(SEED),
               "--batch-size", str(BATCH), "--dtype", "float64", "--device", "cpu",
               "--quiet", *[a for k, v in ARCH.items() for a in ("--arch", f"{k}={v}")],
               *extra]
    full_env = {k: v for k, v in os.environ.items() if k != FAIL_ENV}
    full_env.update({"OMP_NUM_THREADS": "1", **(env or {})})
    return subprocess.run(command, env=full_env, capture_output=True, text=True,
                          timeout=240, check=False)


def config():
    return nh.TrainConfig("traonet", preset="cpu", arch=ARCH, epochs=EPOCHS, seed=SEED,
                          batch_size=BATCH, dtype="float64", device="cpu")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A 2-process torchrun run and a single-process run of the same config and file."""
    folder = tmp_path_factory.mktemp("ddp")
    data = folder / "tiny.h5"
    generate_dataset(56, seed=3, path=data, progress=False)
    done = torchrun(data, folder / "two")
    assert done.returncode == 0, done.stdout + done.stderr
    net, history = nh.train(config(), data, folder / "one", progress=False)
    return data, folder, done, net, history


def _relative(a, b):
    return ((a - b).norm() / a.norm()).item()


def test_two_gloo_processes_match_one_process_to_1e_8(runs):
    _, folder, done, net, history = runs
    two, cfg = nh.load_model(folder / "two")  # the distributed checkpoint loads
    assert cfg["world_size"] == 2 and not two.training
    single = net.state_dict()
    worst = max(_relative(single[k], v) for k, v in two.state_dict().items())
    assert worst < 1e-8, worst
    assert worst > 0  # a different summation order, not the same run twice
    state = load_checkpoint(folder / "two")
    assert state["epoch"] == EPOCHS and state["data_checksum"] == load_checkpoint(
        folder / "one")["data_checksum"]
    for a, b in zip(history, state["history"]):
        assert b["train_loss"] == pytest.approx(a["train_loss"], rel=1e-12)
        assert b["val_loss"] == pytest.approx(a["val_loss"], rel=1e-12)
        assert b["lr"] == a["lr"]
    config_json = (folder / "two" / "config.json").read_text()
    assert '"world_size": 2' in config_json
    assert (folder / "one" / "config.json").read_text().count('"world_size": 1') == 1
    # rank 0 alone reports (and wrote the run directory: no stray temporary files)
    assert done.stdout.count("2 epochs in") == 1
    assert sorted(p.name for p in (folder / "two").iterdir()) == [
        "checkpoint.pt", "config.json", "history.csv"]
    q, p = nh.predict(two, np.zeros((1, 100)) + 1.5, nh.TIMES)
    assert q.shape == p.shape == (1, 100) and np.isfinite(q).all()


@pytest.mark.slow  # two more torchrun launches: about 30 s
def test_a_dead_rank_is_named_and_resume_ends_where_an_uninterrupted_run_does(runs):
    data, folder, _, _, _ = runs
    out = folder / "killed"
    died = torchrun(data, out, env={FAIL_ENV: "1:1"})
    log = died.stdout + died.stderr
    assert died.returncode != 0
    assert ("rank 0 of 2 stopped in epoch 2: rank 1 has died; the checkpoint of epoch 1 "
            "is kept. Run the same command with --resume to continue.") in log, log
    # torchrun's own summary blames rank 1 (exit code 13), not the rank it stopped
    root = log.split("Root Cause (first observed failure):")[1]
    assert "rank      : 1 (local_rank: 1)" in root and "exitcode  : 13" in root
    assert load_checkpoint(out)["epoch"] == 1
    resumed = torchrun(data, out, "--resume")
    assert resumed.returncode == 0, resumed.stdout + resumed.stderr
    reference = load_checkpoint(folder / "two")
    state = load_checkpoint(out)
    assert state["epoch"] == EPOCHS
    for key, value in reference["model"].items():
        assert torch.equal(value, state["model"][key]), key
    assert [h["val_loss"] for h in state["history"]] == [
        h["val_loss"] for h in reference["history"]]


def test_a_global_batch_the_processes_do_not_divide_is_refused(runs, monkeypatch):
    data, folder, _, _, _ = runs
    monkeypatch.setattr(trainer_module, "init_distributed",
                        lambda device: Distributed(rank=0, world_size=2))
    cfg = nh.TrainConfig("traonet", preset="cpu", arch=ARCH, epochs=1, batch_size=15)
    with pytest.raises(ValueError, match=r"^--batch-size 15 is the global batch and must "
                       r"be divisible by the 2 processes; choose a multiple of 2 such "
                       r"as 14 or 16$"):
        nh.train(cfg, data, folder / "odd")
    assert not (folder / "odd").exists()


def test_one_process_from_the_file_matches_the_dataset_in_memory(runs, tmp_path):
    data, _, _, net, _ = runs
    in_memory, _ = nh.train(config(), nh.load_dataset(data), tmp_path, progress=False)
    for (k, a), b in zip(net.state_dict().items(), in_memory.state_dict().values()):
        assert torch.equal(a, b), k


def test_peer_failures_are_told_from_local_errors():
    solo = Distributed()
    assert not solo.is_peer_failure(RuntimeError("gloo: Connection reset by peer"))
    pair = Distributed(rank=0, world_size=2,
                       peers=[(socket.gethostname(), os.getpid())] * 2)
    assert pair.is_peer_failure(RuntimeError("[pair.cc:537] Read error: Connection reset "
                                             "by peer"))
    assert not pair.is_peer_failure(ValueError("bad value"))
    assert not pair.is_peer_failure(RuntimeError("shape mismatch"))
    assert pair.dead_ranks() == []  # this process is alive
    assert issubclass(RankFailed, RuntimeError)


def test_sigterm_while_training_becomes_a_named_failure_not_a_silent_death():
    """torchrun stops the other ranks with SIGTERM when one dies; if that signal beat
    the collective's error, rank 0 died without naming the dead rank (a CI run saw
    it). Inside ``terminate_as_error`` the signal raises, so the failure path runs."""
    import signal

    from nh_operators.training.distributed import Terminated

    pair = Distributed(rank=0, world_size=2,
                       peers=[(socket.gethostname(), os.getpid())] * 2)
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(Terminated, match="rank 0 received SIGTERM") as caught:
        with pair.terminate_as_error():
            os.kill(os.getpid(), signal.SIGTERM)  # handled at the next bytecode
    assert signal.getsignal(signal.SIGTERM) is before  # restored
    assert pair.is_peer_failure(caught.value)
    with Distributed().terminate_as_error():  # one process: the handler is untouched
        assert signal.getsignal(signal.SIGTERM) is before


@pytest.mark.skipif(shutil.which("true") is None, reason="needs a POSIX shell")
def test_a_rank_whose_process_exited_is_found_dead():
    gone = subprocess.Popen(["true"])
    gone.wait()
    pair = Distributed(rank=0, world_size=2,
                       peers=[(socket.gethostname(), os.getpid()),
                              (socket.gethostname(), gone.pid)])
    assert pair.dead_ranks() == [1]
