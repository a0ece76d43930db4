"""Data-parallel training under ``torchrun``: the process group, reductions, rank-0 guards.

``torchrun --nproc_per_node N ...`` starts N copies of ``nh-operators train`` with the
environment variables ``RANK``, ``WORLD_SIZE``, ``LOCAL_RANK``, ``MASTER_ADDR`` and
``MASTER_PORT``; :func:`init_distributed` reads them, opens the process group (gloo on
the CPU, nccl on CUDA) and returns a :class:`Distributed` that the trainer asks for its
rank, its device, sums over all ranks, and whether it is rank 0 (the one that writes
files and draws the progress bar). Without those variables it returns a one-process
:class:`Distributed` whose reductions do nothing, so the same trainer code runs in
both cases.

The network is wrapped in :class:`torch.nn.parallel.DistributedDataParallel` (through
:meth:`Distributed.wrap`), which averages the gradients over the ranks during the
backward pass of DeepXDE's own training step.

When a process of the job dies, the others see a failed collective; they stop with
:class:`RankFailed`, whose message names the dead rank where it can be told (a process
on the same host that has exited), and ``--resume`` continues from the last checkpoint.
"""

import contextlib
import datetime
import inspect
import logging
import os
import signal
import socket
import threading
import time
from typing import Any

import numpy as np
import torch
import torch.distributed as dist
from torch.nn.parallel import DistributedDataParallel

from .config import resolve_device

log = logging.getLogger(__name__)

__all__ = ["Distributed", "RankFailed", "init_distributed"]

#: Hidden fault injection for the tests: "RANK:EPOCH" makes that rank exit (exit code
#: 13, no clean-up, like a crash) right after that epoch's checkpoint is written.
FAIL_ENV = "NH_OPERATORS_FAIL_RANK_AFTER_EPOCH"
#: Seconds a surviving rank waits after reporting a dead peer, so that ``torchrun``
#: sees the dead rank's exit first and names it as the root cause.
GRACE_SECONDS = 3.0
#: Words of the errors a collective raises when another rank has gone (gloo raises a
#: plain RuntimeError from inside DDP's backward; newer code raises DistError).
_PEER_WORDS = ("gloo", "nccl", "connection reset", "connection closed", "broken pipe",
               "processgroup", "timed out")


class Terminated(RuntimeError):
    """SIGTERM reached a rank during training (torchrun stops the others this way when
    one rank fails)."""


class RankFailed(RuntimeError):
    """A process of a distributed run died or lost contact; this one stopped too."""


class _Wrapped(DistributedDataParallel):
    """``DistributedDataParallel`` that lends the wrapped network's attributes.

    DeepXDE reads ``net.regularizer`` and the training data reads ``net.kl`` (VaRONet)
    on the object it was given; plain DDP has neither.
    """

    def __getattr__(self, name):
        try:
            return super().__getattr__(name)
        except AttributeError:
            return getattr(self.module, name)


class Distributed:
    """This process's place in a data-parallel run.

    Args:
        rank: global rank of this process, in [0, world_size).
        world_size: number of processes N.
        local_rank: rank on this machine (picks the GPU).
        device: the ``torch.device`` this rank trains on (default: the CPU).
        backend: "gloo" or "nccl", or ``None`` for a single process.
        peers: (host, pid) of every rank, for naming a dead one.

    Example:
        >>> d = Distributed()
        >>> d.rank, d.world_size, d.is_main, d.active
        (0, 1, True, False)
        >>> d.sum([1.5, 2.0])
        array([1.5, 2. ])
    """

    def __init__(self, rank=0, world_size=1, local_rank=0, device=None, backend=None,
                 peers=None):
        self.rank, self.world_size, self.local_rank = rank, world_size, local_rank
        self.device = torch.device("cpu") if device is None else device
        self.backend = backend
        self.peers = peers or [(socket.gethostname(), os.getpid())]
        self.owns_group = False

    @property
    def active(self):
        """True when there is more than one process."""
        return self.world_size > 1

    @property
    def is_main(self):
        """True on rank 0, the one that writes files, logs and draws the progress bar."""
        return self.rank == 0

    def sum(self, values):
        """Sum of float64 values over all ranks.

        Args:
            values: numbers, shape (k,).

        Returns:
            numpy array (k,), the same on every rank.
        """
        tensor = torch.as_tensor(np.asarray(values, dtype=np.float64))
        if self.active:
            tensor = tensor.to(self.device)
            dist.all_reduce(tensor, op=dist.ReduceOp.SUM)
        return tensor.cpu().numpy()

    def broadcast(self, obj):
        """Rank 0's ``obj`` on every rank (any picklable object)."""
        if not self.active:
            return obj
        box = [obj]
        dist.broadcast_object_list(box, src=0, device=self.device)
        return box[0]

    def barrier(self):
        """Wait until every rank gets here."""
        if self.active:
            dist.barrier(device_ids=[self.device.index] if self.device.type == "cuda"
                         else None)

    def wrap(self, net):
        """The network for DeepXDE: wrapped in DistributedDataParallel when N > 1.

        The parameters are broadcast from rank 0; gradients are averaged over the ranks
        during ``backward``. Attribute reads fall through to ``net``.
        """
        if not self.active:
            return net
        ids = [self.device.index] if self.device.type == "cuda" else None
        # no buffer sync in forward (the networks keep no state in buffers); newer
        # torch names the option forward_sync_buffers
        sync = ("forward_sync_buffers" if "forward_sync_buffers" in
                inspect.signature(DistributedDataParallel.__init__).parameters
                else "broadcast_buffers")
        options: dict[str, Any] = {sync: False}
        return _Wrapped(net, device_ids=ids, **options)

    def maybe_fail(self, epoch):
        """Fault injection (``NH_OPERATORS_FAIL_RANK_AFTER_EPOCH=RANK:EPOCH``)."""
        rank, _, when = os.environ.get(FAIL_ENV, "").partition(":")
        if self.active and rank == str(self.rank) and when == str(epoch):
            log.error("rank %d of %d: exiting after epoch %d (%s)", self.rank,
                      self.world_size, epoch, FAIL_ENV)
            logging.shutdown()
            os._exit(13)

    def is_peer_failure(self, exc):
        """Whether ``exc`` (raised on this rank) comes from another rank having gone."""
        if not self.active or not isinstance(exc, RuntimeError):
            return False
        if isinstance(exc, (dist.DistError, Terminated)) or self.dead_ranks():
            return True
        return any(word in str(exc).lower() for word in _PEER_WORDS)

    def dead_ranks(self):
        """Ranks on this host whose process has exited (others cannot be told)."""
        host = socket.gethostname()
        return [r for r, (h, pid) in enumerate(self.peers)
                if r != self.rank and h == host and not _alive(pid)]

    def failure(self, exc, epoch, last_checkpoint):
        """A :class:`RankFailed` for a collective that failed with ``exc`` in ``epoch``,
        logged at once (the process may be terminated during the grace wait)."""
        dead = self.dead_ranks()
        who = (f"rank {dead[0]} has died" if len(dead) == 1 else
               f"ranks {dead} have died" if dead else
               f"lost contact with another rank ({type(exc).__name__}: {exc})")
        kept = (f"the checkpoint of epoch {last_checkpoint} is kept" if last_checkpoint
                else "no epoch finished, so there is no checkpoint")
        message = (f"rank {self.rank} of {self.world_size} stopped in epoch {epoch}: "
                   f"{who}; {kept}. Run the same command with --resume to continue.")
        log.error(message)
        for handler in logging.getLogger().handlers:
            handler.flush()
        time.sleep(GRACE_SECONDS)
        return RankFailed(message)

    @contextlib.contextmanager
    def terminate_as_error(self):
        """While training with N > 1 ranks, SIGTERM raises :class:`Terminated` instead of
        ending the process at once, so a rank that torchrun stops because another rank
        died still names the dead rank and the kept checkpoint (:meth:`failure`) rather
        than racing torchrun's signal. Outside the main thread, or with one process,
        nothing changes."""
        if not self.active or threading.current_thread() is not threading.main_thread():
            yield
            return

        def raise_terminated(signum, frame):
            raise Terminated(f"rank {self.rank} received SIGTERM")

        before = signal.signal(signal.SIGTERM, raise_terminated)
        try:
            yield
        finally:
            signal.signal(signal.SIGTERM, before)

    def close(self):
        """Destroy the process group if :func:`init_distributed` created it."""
        if self.owns_group and dist.is_initialized():
            dist.destroy_process_group()
            self.owns_group = False


def _alive(pid):
    try:
        with open(f"/proc/{pid}/stat") as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    except OSError:
        return True  # no /proc: cannot tell
    return state not in ("Z", "X")


def init_distributed(device="auto", timeout_minutes=30):
    """Join the torchrun job this process belongs to, if any.

    Args:
        device: the config's device. "auto" and "cuda" become ``cuda:LOCAL_RANK`` under
            torchrun when CUDA is present; "cpu" keeps every rank on the CPU.
        timeout_minutes: how long a collective waits for a silent rank.

    Returns:
        :class:`Distributed`: one process when ``WORLD_SIZE`` is unset or 1; otherwise
        rank and world size from torchrun's variables, the process group open (gloo on
        the CPU, nccl on CUDA) unless the caller had opened one.

    Raises:
        ValueError: if CUDA is asked for and not available.
    """
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        return Distributed(device=resolve_device(device))
    rank = int(os.environ["RANK"])
    local = int(os.environ.get("LOCAL_RANK", "0"))
    dev = resolve_device(device)
    if dev.type == "cuda" and dev.index is None:
        dev = torch.device("cuda", local)
    backend = "nccl" if dev.type == "cuda" else "gloo"
    if dev.type == "cuda":
        torch.cuda.set_device(dev)
    owns = not dist.is_initialized()
    if owns:
        dist.init_process_group(backend, timeout=datetime.timedelta(minutes=timeout_minutes))
    elif dist.get_backend() != backend:
        backend = dist.get_backend()
    ctx = Distributed(rank, world, local, dev, backend)
    ctx.owns_group = owns
    peers = [None] * world
    dist.all_gather_object(peers, (socket.gethostname(), os.getpid()))
    ctx.peers = peers
    return ctx
