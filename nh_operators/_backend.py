"""Select DeepXDE's PyTorch backend quietly, before anything imports deepxde."""

import contextlib
import io
import os
import sys
import threading


def select_pytorch_backend():
    """Choose DeepXDE's PyTorch backend without importing anything (run at package import).

    Sets ``DDE_BACKEND=pytorch`` when no backend is chosen, so that deepxde, imported
    later by us or by the user, neither searches for a backend nor writes
    ``~/.deepxde/config.json``.

    Raises:
        ImportError: if ``DDE_BACKEND`` names another backend, or deepxde was already
            imported with another backend.
    """
    chosen = os.environ.get("DDE_BACKEND", os.environ.get("DDEBACKEND"))
    deepxde = sys.modules.get("deepxde")
    if deepxde is not None:
        name = deepxde.backend.backend_name
        if name != "pytorch":
            raise ImportError(
                f"deepxde was already imported with the {name!r} backend; nh_operators "
                "needs 'pytorch'. Set DDE_BACKEND=pytorch before importing deepxde."
            )
        return
    if chosen is None:
        os.environ["DDE_BACKEND"] = "pytorch"
    elif chosen.lower() != "pytorch":
        raise ImportError(
            f"DDE_BACKEND={chosen!r} selects another DeepXDE backend; nh_operators needs "
            "'pytorch'. Unset DDE_BACKEND or set it to 'pytorch'."
        )


def ensure_pytorch_backend():
    """Import deepxde with its PyTorch backend and return the module.

    When no backend is chosen (``DDE_BACKEND`` unset), PyTorch is selected through the
    environment, so deepxde neither searches for a backend nor writes
    ``~/.deepxde/config.json``; its "Using backend" banner is swallowed.

    deepxde's import-time ``torch.set_default_device("cuda")`` (with CUDA present) is
    undone: torch's default device stays what it was.

    Raises:
        ImportError: if ``DDE_BACKEND`` names another backend, or deepxde was already
            imported with another backend.
    """
    select_pytorch_backend()
    if "deepxde" in sys.modules:
        return sys.modules["deepxde"]
    import torch

    device = torch.get_default_device()
    with contextlib.redirect_stderr(io.StringIO()):
        import deepxde
    # With CUDA present deepxde calls torch.set_default_device("cuda") on import;
    # put the user's default back (the trainer picks its device explicitly). Only then:
    # a default-device mode, even "cpu", adds a __torch_function__ hop to every torch
    # call (about 20 µs per DeepONet forward).
    if torch.get_default_device() != device:
        torch.set_default_device(None if device.type == "cpu" else device)
    return deepxde


_LOCAL = threading.local()  # this thread's single_threaded blocks: depth, torch limited


@contextlib.contextmanager
def single_threaded():
    """Run torch and numba on one thread inside the block (restored afterwards).

    One potential gains nothing from threads, and on a busy machine a multi-threaded
    call waits for a time slice on every core: a batch-1 solve took 16 ms instead of
    0.5 ms (numba) and 80 ms instead of 2.4 ms (torch) on this 2-core machine while a
    training run was going.

    The counts are chosen once per call path: a block inside another block of the same
    thread costs nothing (it only limits torch if torch was imported since the outer
    block began), and a count already at 1 is not set again.

    Not thread-safe for torch: numba's count is per thread, torch's process-wide, so
    torch work of other threads also runs on one thread inside the block, and two blocks
    that overlap in different threads restore torch's count in the order they end (the
    first to end puts back what it saw, possibly 1, until the other ends).

    Example:
        >>> import numba
        >>> with single_threaded():
        ...     with single_threaded():
        ...         inner = numba.get_num_threads()
        >>> inner
        1
    """
    import numba

    depth = getattr(_LOCAL, "depth", 0)
    outer = depth == 0
    n_numba = numba.get_num_threads() if outer else 1
    if n_numba != 1:
        numba.set_num_threads(1)
    # torch not imported: nothing of torch's runs in the block (until a nested block)
    torch = None if getattr(_LOCAL, "torch", False) else sys.modules.get("torch")
    n_torch = torch.get_num_threads() if torch is not None else 1
    if torch is not None and n_torch != 1:
        torch.set_num_threads(1)
    if torch is not None:
        _LOCAL.torch = True
    _LOCAL.depth = depth + 1
    try:
        yield
    finally:
        _LOCAL.depth = depth
        if torch is not None:
            _LOCAL.torch = False
            if n_torch != 1:
                torch.set_num_threads(n_torch)
        if n_numba != 1:
            numba.set_num_threads(n_numba)


@contextlib.contextmanager
def torch_threads(n: "int | None"):
    """Run torch on ``n`` intra-op threads inside the block, restored afterwards (numba's
    count is left alone); ``None`` or a count already at ``n`` changes nothing.

    Not thread-safe, for the reason :func:`single_threaded` gives: torch's count is
    process-wide.

    Example:
        >>> import torch
        >>> before = torch.get_num_threads()
        >>> with torch_threads(1):
        ...     inside = torch.get_num_threads()
        >>> inside, torch.get_num_threads() == before
        (1, True)
    """
    import torch

    before = torch.get_num_threads()
    if n is None or n == before:
        yield
        return
    torch.set_num_threads(n)
    try:
        yield
    finally:
        torch.set_num_threads(before)
