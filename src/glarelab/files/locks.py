"""One process at a time: an exclusive, non-blocking lock on a file (:class:`ProcessLock`).

A participant's session (:class:`glarelab.experiments.data.SessionLock`) and a photometer
measurement (:class:`glarelab.display.measure.MeasurementLock`) are each held by one process:
two would interleave their records and overwrite each other's saves. The operating system
releases the lock when the process ends, however it ends (``flock`` on POSIX, ``msvcrt`` on
Windows), so a killed process never leaves a stale lock. The lock file holds the holder's
process id and host, for the refusal; it is removed while still held when the holder releases
it, and a process that took the lock of a file removed meanwhile takes the new one instead.
"""

from __future__ import annotations

import contextlib
import os
import socket
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

__all__ = ["ProcessLock", "waiting_for"]


class ProcessLock:
    """Hold ``path`` for this process: ``lock.acquire()`` … ``lock.release()``, or ``with``.

    Parameters
    ----------
    path
        The lock file; its folder is created.
    refusal
        Makes the exception raised when another process holds the lock, from the holder's
        description (``"pid 123 on host"``).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> with ProcessLock(folder / ".a.lock", refusal=ValueError):
    ...     (folder / ".a.lock").exists()
    True
    >>> (folder / ".a.lock").exists()
    False
    """

    def __init__(self, path: str | Path, *, refusal: Callable[[str], Exception]):
        self.path = Path(path)
        self.refusal = refusal
        self._fd: int | None = None

    def acquire(self) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                _lock(fd)
            except OSError:
                holder = os.read(fd, 200).decode("utf-8", "replace").strip() or "unknown"
                os.close(fd)
                raise self.refusal(holder) from None
            try:  # the holder before us removes the file as it leaves: lock the one there now
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        try:  # who holds it, for the refusal (a full disk only loses the name)
            os.ftruncate(fd, 0)
            os.write(fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode())
        except OSError:
            pass
        self._fd = fd

    def release(self) -> None:
        if self._fd is not None:
            with contextlib.suppress(OSError):  # Windows keeps an open file: it stays there
                os.unlink(self.path)
            os.close(self._fd)  # closing the descriptor releases the lock
            self._fd = None

    def __enter__(self) -> ProcessLock:
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()


@contextlib.contextmanager
def waiting_for(path: str | Path, *, wait_s: float, poll_s: float, what: str) -> Iterator[None]:
    """Hold the lock ``path`` for the ``with`` block, waiting while another process holds it
    (a :class:`ProcessLock` refuses at once): for work the next process needs done, not
    refused (a folder's listing, a cached stimulus set being built).

    Parameters
    ----------
    path
        The lock file.
    wait_s
        The longest wait, s.
    poll_s
        How often to try again, s.
    what
        What is waited for, for the message of a wait that ran out.

    Raises
    ------
    TimeoutError
        When another process held it for ``wait_s``, naming it and ``what``.

    Examples
    --------
    >>> import tempfile
    >>> lock = Path(tempfile.mkdtemp()) / ".a.lock"
    >>> with waiting_for(lock, wait_s=1.0, poll_s=0.01, what="a"):
    ...     lock.exists()
    True
    """
    lock = ProcessLock(path, refusal=BlockingIOError)
    deadline = time.monotonic() + wait_s
    while True:
        try:
            lock.acquire()
            break
        except BlockingIOError as held:
            if time.monotonic() > deadline:
                raise TimeoutError(
                    f"{what}: another glarelab process ({held}) has held it for {wait_s:.0f} s"
                ) from None
            time.sleep(poll_s)
    try:
        yield
    finally:
        lock.release()


if sys.platform == "win32":  # pragma: no cover - the lab machines of CI are Linux

    def _lock(fd: int) -> None:
        import msvcrt

        os.lseek(fd, 0, os.SEEK_SET)
        msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)

else:

    def _lock(fd: int) -> None:
        import fcntl

        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
