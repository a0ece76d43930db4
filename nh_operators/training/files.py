"""The files of a run directory, and the atomic write every file of the package goes through.

Torch-free, so that listing or checking run directories and shipped weights loads no
network code.
"""

import os
import tempfile
from pathlib import Path

__all__ = ["CHECKPOINT", "CONFIG", "HISTORY", "write_atomic"]

#: File name of a run's checkpoint inside its run directory.
CHECKPOINT = "checkpoint.pt"
#: File name of a run's resolved training config.
CONFIG = "config.json"
#: File name of a run's loss history, one row per epoch.
HISTORY = "history.csv"


def write_atomic(path, data):
    """Write bytes to ``path`` through a temporary file in the same folder and a rename."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would hide shipped files from others
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
