"""Files written whole or not at all.

Every file glarelab writes (images, tables, reports, manifests, calibrations, kernels) is
written to a temporary name in its own folder, flushed to the disk (``fsync``) and renamed over
its final name only when complete: an interrupted or failed write (a full disk, Ctrl-C, a
killed process) leaves the earlier file, or no file, never a partial one. The rename replaces
a symbolic link at the final name rather than writing through it.

A temporary file is named ``.NAME.partial-PID-THREAD.SUFFIX`` (so two threads, or two
processes, writing one file never share it); one left by a process that was killed is removed by
the next write of the same file. Session CSVs are the one exception: they are appended to
and flushed trial by trial (:mod:`glarelab.experiments.data`), so that a crash loses no trial.
"""

from __future__ import annotations

import contextlib
import os
import stat
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import IO

__all__ = [
    "atomic_open",
    "atomic_path",
    "fsync_folder",
    "short_name",
    "special_file",
    "write_bytes",
    "write_text",
]

PARTIAL = ".partial-"  # in the name of a file being written
NAME_MAX_BYTES = 255  # a file name's limit on ext4, XFS, Btrfs, APFS, tmpfs (NTFS: 255 UTF-16)
_OWNER_BYTES = 28  # PID-THREAD: 7 digits, a dash, 20 digits


def short_name(name: str, *, room: int) -> str:
    """``name``, or a shorter one that stands for it, so that ``room`` more bytes still fit in a
    file name (:data:`NAME_MAX_BYTES`): the temporary and staging names built from a legal
    long name are legal too, and refused, if ever, before any work rather than after it.

    Parameters
    ----------
    name
        A file or folder name.
    room
        The bytes (UTF-8) that will be added to it.

    Returns
    -------
    str
        ``name`` when it fits; else its start, ``~`` and 12 hexadecimal digits of its SHA-256
        (distinct names stay distinct).

    Raises
    ------
    ValueError
        For a ``name`` that is not a str, or a ``room`` that is not a whole number >= 0.

    Examples
    --------
    >>> short_name("table", room=40)
    'table'
    >>> long = "x" * 250
    >>> len(short_name(long, room=40).encode()) + 40 <= NAME_MAX_BYTES
    True
    """
    if not isinstance(name, str):
        raise ValueError(f"name must be a file name (a str); got {name!r}")
    from .values import is_whole  # numpy, not needed to import this module

    if not is_whole(room) or room < 0:
        raise ValueError(f"room must be a whole number of bytes >= 0; got {room!r}")
    if len(name.encode()) + room <= NAME_MAX_BYTES:
        return name
    import hashlib

    tag = "~" + hashlib.sha256(name.encode()).hexdigest()[:12]
    keep = max(NAME_MAX_BYTES - room - len(tag), 1)
    return name.encode()[:keep].decode(errors="ignore") + tag


def _temporary_stem(path: Path) -> str:
    return short_name(path.stem, room=1 + len(PARTIAL) + _OWNER_BYTES + len(path.suffix.encode()))


def _temporary(path: Path) -> Path:
    # the suffix stays last: Pillow, matplotlib and pandas choose the format by it
    owner = f"{os.getpid()}-{threading.get_ident()}"
    return path.with_name(f".{_temporary_stem(path)}{PARTIAL}{owner}{path.suffix}")


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (psutil: on every system; ``os.kill(pid, 0)`` would
    send CTRL_C_EVENT on Windows, where signal 0 is that event)."""
    import psutil

    return psutil.pid_exists(pid)


def _remove_stale(path: Path) -> None:
    """Remove the temporary files of ``path`` left by processes that were killed."""
    prefix = f".{_temporary_stem(path)}{PARTIAL}"
    try:
        candidates = list(path.parent.glob(f"{glob_escape(prefix)}*{glob_escape(path.suffix)}"))
    except OSError:
        return
    for candidate in candidates:
        owner = candidate.name[len(prefix) : len(candidate.name) - len(path.suffix)]
        pid = owner.split("-")[0]
        if pid.isdigit() and int(pid) != os.getpid() and not _alive(int(pid)):
            with contextlib.suppress(OSError):
                candidate.unlink()


def glob_escape(text: str) -> str:
    """``text`` with the glob pattern characters quoted."""
    return "".join(f"[{c}]" if c in "*?[" else c for c in text)


def fsync_folder(folder: str | Path) -> None:
    """Flush a folder's entries (a rename into it) to the disk, where the system allows.

    Parameters
    ----------
    folder
        The folder whose entries are flushed. A folder that cannot be opened, or a system
        that cannot flush folders, is passed over silently: the rename already happened.
    """
    try:
        handle = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return
    try:
        os.fsync(handle)
    except OSError:
        pass
    finally:
        os.close(handle)


def _fsync_file(path: Path) -> None:
    handle = os.open(path, os.O_RDONLY)
    try:
        os.fsync(handle)
    finally:
        os.close(handle)


_SPECIAL = (  # a folder is left to the rename, which fails on it
    (stat.S_ISCHR, "a character device (as /dev/null)"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a named pipe (FIFO)"),
    (stat.S_ISSOCK, "a socket"),
)


def special_file(path: str | Path) -> str | None:
    """What ``path`` is if it is a device, a named pipe or a socket (``'a named pipe
    (FIFO)'``), which a rename over it would replace; None for anything else or nothing.

    Parameters
    ----------
    path
        The path, not followed if it is a link.

    Returns
    -------
    str or None
        The kind, for a message, or None.
    """
    try:
        mode = os.lstat(path).st_mode
    except OSError:  # not there (or not reachable: the write says why)
        return None
    return next((what for test, what in _SPECIAL if test(mode)), None)


def _refuse_special(path: Path) -> None:
    """Refuse a ``path`` that is there and is no regular file: the rename that puts a new
    file in place would replace the folder's entry (a device, such as /dev/null for root,
    would be gone)."""
    what = special_file(path)
    if what is not None:
        raise ValueError(
            f"{path}: {what}, not a file; glarelab writes a file whole and renames it into "
            "place, which would replace it; give a file's path"
        )


@contextlib.contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path to write ``path``'s new content to; renamed over ``path`` when the
    block ends without an error, removed when it does not.

    Parameters
    ----------
    path
        The file to write. Its folder must exist.

    Yields
    ------
    pathlib.Path
        A new name in the same folder, ending in the same suffix (so that writers choosing a
        format by the suffix choose the same one).

    Raises
    ------
    OSError
        When the content cannot be written or renamed (a full disk: nothing is left behind,
        and an earlier ``path`` is as it was).
    ValueError
        When ``path`` is a device, a named pipe or a socket (the rename would replace it).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> with atomic_path(folder / "table.csv") as temporary:
    ...     _ = temporary.write_text("a,b\\n1,2\\n")
    >>> (folder / "table.csv").read_text()
    'a,b\\n1,2\\n'
    >>> sorted(p.name for p in folder.iterdir())
    ['table.csv']
    """
    path = Path(path)
    _refuse_special(path)
    _remove_stale(path)
    temporary = _temporary(path)
    try:
        yield temporary
        if not temporary.is_file():
            raise FileNotFoundError(f"{path}: nothing was written")
        _fsync_file(temporary)
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            temporary.unlink()
        raise
    fsync_folder(path.parent)


@contextlib.contextmanager
def atomic_open(
    path: str | Path,
    mode: str = "w",
    *,
    encoding: str | None = "utf-8",
    newline: str | None = None,
) -> Iterator[IO]:
    """``open(path, mode)`` whose content replaces ``path`` only when the block completes.

    Parameters
    ----------
    path
        The file to write, through a temporary file beside it (:func:`atomic_path`). Its folder
        must exist.
    mode
        ``'w'`` (text, default) or ``'wb'`` (bytes).
    encoding
        The text encoding in mode ``'w'``; default UTF-8. Not used in mode ``'wb'``.
    newline
        As for :func:`open` in mode ``'w'``: ``None`` (default) writes ``\\n`` as the
        platform's line ending, ``''`` or ``'\\n'`` writes it as is.

    Yields
    ------
    typing.IO
        The open temporary file.

    Raises
    ------
    ValueError
        If ``mode`` is neither ``'w'`` nor ``'wb'``.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "notes.txt"
    >>> with atomic_open(path) as handle:
    ...     _ = handle.write("complete\\n")
    >>> path.read_text()
    'complete\\n'
    """
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb'; got {mode!r}")
    with atomic_path(path) as temporary:
        try:
            if mode == "wb":
                handle = temporary.open("wb")
            else:
                handle = temporary.open("w", encoding=encoding, newline=newline)
        except OSError as error:  # named by the file asked for, not its temporary name
            raise type(error)(error.errno, error.strerror, str(path)) from None
        with handle:
            yield handle


def write_text(path: str | Path, text: str, *, encoding: str = "utf-8") -> Path:
    """Write ``text`` to ``path`` whole or not at all (:func:`atomic_path`).

    Parameters
    ----------
    path
        The file to write; an earlier file of that name is replaced only once ``text`` is on
        the disk.
    text
        The whole content.
    encoding
        The text encoding; default UTF-8.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    with atomic_open(path, "w", encoding=encoding) as handle:
        handle.write(text)
    return Path(path)


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` to ``path`` whole or not at all (:func:`atomic_path`).

    Parameters
    ----------
    path
        The file to write; an earlier file of that name is replaced only once ``data`` is on
        the disk.
    data
        The whole content.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    with atomic_open(path, "wb") as handle:
        handle.write(data)
    return Path(path)
