"""Select DeepXDE's PyTorch backend quietly, before anything imports deepxde."""

import contextlib
import io
import os
import sys


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
    chosen = os.environ.get("DDE_BACKEND", os.environ.get("DDEBACKEND"))
    if "deepxde" in sys.modules:
        import deepxde

        name = deepxde.backend.backend_name
        if name != "pytorch":
            raise ImportError(
                f"deepxde was already imported with the {name!r} backend; nh_operators "
                "needs 'pytorch'. Set DDE_BACKEND=pytorch before importing deepxde."
            )
        return deepxde
    if chosen is None:
        os.environ["DDE_BACKEND"] = "pytorch"
    elif chosen.lower() != "pytorch":
        raise ImportError(
            f"DDE_BACKEND={chosen!r} selects another DeepXDE backend; nh_operators needs "
            "'pytorch'. Unset DDE_BACKEND or set it to 'pytorch'."
        )
    import torch

    device = torch.get_default_device()
    with contextlib.redirect_stderr(io.StringIO()):
        import deepxde
    # With CUDA present deepxde calls torch.set_default_device("cuda") on import;
    # put the user's default back (the trainer picks its device explicitly).
    torch.set_default_device(device)
    return deepxde
