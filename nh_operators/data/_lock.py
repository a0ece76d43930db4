"""An exclusive lock on an output path, taken before any file is opened for writing."""

import contextlib
import os

try:
    import fcntl
except ImportError:  # not POSIX: exclusive creation of the lock file instead
    fcntl = None

__all__ = ["exclusive_lock"]


@contextlib.contextmanager
def exclusive_lock(lock_path, what):
    """Hold ``lock_path`` exclusively for the block; another holder makes it fail at once.

    Args:
        lock_path: the lock file (created; removed when the block ends).
        what: the output the lock protects, for the message.

    Raises:
        FileExistsError: if another process holds the lock, naming its pid.

    Example:
        >>> import tempfile, os
        >>> lock = os.path.join(tempfile.mkdtemp(), "x.h5.lock")
        >>> with exclusive_lock(lock, "x.h5"):
        ...     os.path.exists(lock)
        True
    """
    flags = os.O_RDWR | os.O_CREAT | (os.O_EXCL if fcntl is None else 0)
    try:
        fd = os.open(lock_path, flags, 0o644)
    except FileExistsError:
        raise FileExistsError(_busy(lock_path, what)) from None
    try:
        if fcntl is not None:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                raise FileExistsError(_busy(lock_path, what)) from None
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        try:
            yield
        finally:
            with contextlib.suppress(OSError):
                os.unlink(lock_path)
    finally:
        os.close(fd)


def _busy(lock_path, what):
    try:
        with open(lock_path, encoding="utf-8") as f:
            pid = f.read().strip() or "?"
    except OSError:
        pid = "?"
    return (f"another process (pid {pid}) is writing {what}; wait for it to finish or choose "
            f"another output (lock: {lock_path})")
