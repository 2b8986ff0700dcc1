"""Output folders that never take someone else's files.

Every folder a command writes holds a listing, ``.glarelab-files.json``, of the files glarelab
wrote there (and of what kind of output they are). A command may replace or overwrite only
files in that listing: a folder holding anything else — a participant's data, a user's notes,
another program's ``manifest.json``, a symbolic link — is refused before anything is written.

A stimulus set or a report is built in a staging folder next to its destination and moved into
place only when complete: a failed build leaves the earlier output as it was, and a rebuild
leaves no file of the earlier output behind. Commands that add named files to a folder shared
with other files (``docs``, ``looks``, ``gallery``) overwrite only files the listing names,
and refuse one edited since they wrote it (its content is recorded, :func:`record_written`).
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import errno
import hashlib
import json
import os
import shutil
import warnings
from collections.abc import Iterable, Iterator
from pathlib import Path

from glarelab.files.atomic import _alive, fsync_folder, glob_escape, short_name, write_text
from glarelab.files.inputs import loads_json
from glarelab.files.locks import ProcessLock, waiting_for

__all__ = [
    "LISTING",
    "check_replaceable",
    "claim_files",
    "edited_since",
    "files_claimed",
    "list_files",
    "listed_files",
    "output_lock",
    "record_files",
    "record_written",
    "replace_folder",
    "restore_folder",
    "staging_folder",
    "without_link_loop",
]

LISTING = ".glarelab-files.json"  # the files glarelab wrote into a folder, by kind of output
LISTING_LOCK = ".glarelab-files.lock"  # held while the listing is read, changed and written


UNWRITTEN = ""  # the sha256 recorded for a file claimed before it existed, until it is written


def _listing(folder: Path, *, unwritten: bool = False) -> dict[str, str]:
    """``{relative path: kind}`` of the files glarelab wrote into ``folder`` (empty if none).

    A file claimed while it did not exist whose write never completed (its content still
    :data:`UNWRITTEN`) is not glarelab's once something is there: a write that failed on a
    full disk does not make a user's file saved under its name later glarelab's."""
    try:
        listing = loads_json((folder / LISTING).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    files = listing.get("files") if isinstance(listing, dict) else None
    if not isinstance(files, dict):
        return {}
    if unwritten:  # as listed, unwritten files too
        return {str(name): str(kind) for name, kind in files.items()}
    hashes = listing.get("sha256")
    claimed = {
        str(name)
        for name, digest in (hashes.items() if isinstance(hashes, dict) else ())
        if digest == UNWRITTEN
    }
    return {
        str(name): str(kind)
        for name, kind in files.items()
        if str(name) not in claimed
        or not ((folder / str(name)).exists() or (folder / str(name)).is_symlink())
    }


def _claimed_hashes(folder: Path, names: Iterable[str]) -> dict[str, str]:
    """The recorded content of the listed files, with ``names`` (about to be written) marked
    :data:`UNWRITTEN` where no file is there yet, and unrecorded where one is."""
    names = list(names)
    absent = {
        n: UNWRITTEN for n in names if not (folder / n).exists() and not (folder / n).is_symlink()
    }
    return _hashes_but(folder, names) | absent


def _hashes(folder: Path) -> dict[str, str]:
    """``{relative path: sha256}`` of the files as glarelab wrote them into ``folder`` (empty
    for a listing written before the listing kept them)."""
    try:
        listing = loads_json((folder / LISTING).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    hashes = listing.get("sha256") if isinstance(listing, dict) else None
    if not isinstance(hashes, dict):
        return {}
    return {str(name): str(digest) for name, digest in hashes.items()}


def _sha256(path: Path) -> str | None:
    """The sha256 of a regular file's content; None for a symbolic link or anything else."""
    if path.is_symlink() or not path.is_file():
        return None
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


SYSTEM_FILES = frozenset({".DS_Store", "Thumbs.db", "desktop.ini"})  # a file browser's own


def is_system_file(name: str) -> bool:
    """Whether a file of this name is one a file browser writes by itself: macOS Finder's
    ``.DS_Store`` and the ``._NAME`` resource forks it leaves on USB sticks and network
    drives, Windows Explorer's ``Thumbs.db`` and ``desktop.ini``. Copying a stimulus set or
    opening a report folder leaves them; they are no one's data.

    Parameters
    ----------
    name
        A file's name (not its path).

    Returns
    -------
    bool
        True for those names.

    Examples
    --------
    >>> is_system_file(".DS_Store"), is_system_file("._image.exr"), is_system_file("a.exr")
    (True, True, False)
    """
    return name in SYSTEM_FILES or name.startswith("._")


def _entries(folder: Path) -> list[str]:
    """Every file, folder link and file link under ``folder`` (symbolic links not followed)."""
    found = []
    for root, dirs, files in os.walk(folder, followlinks=False):
        here = Path(root)
        links = [d for d in dirs if (here / d).is_symlink()]
        dirs[:] = [d for d in dirs if d not in links]
        for name in [*files, *links]:
            if not is_system_file(name):
                found.append((here / name).relative_to(folder).as_posix())
    return sorted(entry for entry in found if entry != LISTING)


def _inside(path: Path, folder: Path) -> bool:
    path, folder = path.resolve(), folder.resolve()
    return path == folder or folder in path.parents


def without_link_loop(path: str | Path, *, what: str) -> Path:
    """``path``, when no loop of symbolic links lies on its way (checked before any work, as
    ``Path.resolve`` would raise RuntimeError at the end of it).

    Parameters
    ----------
    path
        A file or folder to be written; it need not exist.
    what
        What will be written there, for the message.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        If resolving ``path`` meets a loop of symbolic links (naming it).

    Examples
    --------
    >>> without_link_loop("results/report", what="report")
    PosixPath('results/report')
    """
    path = Path(path)
    try:
        path.resolve()
    except (RuntimeError, OSError) as error:  # RuntimeError up to Python 3.12, then ELOOP
        if isinstance(error, OSError) and error.errno != errno.ELOOP:
            raise
        raise ValueError(
            f"{path}: a loop of symbolic links on the way; the {what} needs a path without one"
        ) from None
    return path


def check_replaceable(
    out: str | Path, *, kind: str, what: str, inputs: Iterable[str | Path] = ()
) -> Path:
    """``out`` as the folder of a ``what`` that replaces it whole: new, empty, or holding only
    files an earlier output of the same ``kind`` wrote (as its listing says).

    Parameters
    ----------
    out
        The folder the output will replace whole; it need not exist.
    kind
        The kind of output the listing records the files as (``'stimulus set'``, ``'report'``,
        ``'power'``, ...): an output replaces or overwrites only files of its own kind.
    what
        The output's name in the error messages (``'stimulus set'``, ``'demo folder'``).
    inputs
        The files and folders the command reads: none may be inside ``out``, which the output
        replaces whole.

    Returns
    -------
    pathlib.Path
        ``out``.

    Raises
    ------
    ValueError
        If ``out`` is a file, holds a file glarelab did not write there (named), or holds one of
        the command's ``inputs``.
    """
    out = without_link_loop(out, what=what)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out} is a file; a {what} needs a folder")
    for source in inputs:
        if _inside(Path(source), out):
            raise ValueError(
                f"{source} is inside {out}, which the {what} replaces whole: give another "
                "folder (nothing was changed)"
            )
    if not out.is_dir():
        return out
    listed = _listing(out)
    entries = _entries(out)
    foreign = [e for e in entries if listed.get(e) != kind]
    if foreign:
        raise ValueError(
            f"{out} holds files that are not an earlier {what} glarelab wrote "
            f"({_shown(foreign)}); the {what} replaces its folder whole, so give a new or "
            "empty folder as --out (nothing was changed)"
        )
    written = _hashes(out)
    edited = [e for e in entries if e in written and _sha256(out / e) != written[e]]
    if edited:
        raise ValueError(
            f"{out} holds files edited since glarelab wrote them ({_shown(edited)}); the "
            f"{what} replaces its folder whole, so copy what you added elsewhere and remove "
            "the edited files, or give another folder as --out (nothing was changed)"
        )
    return out


def _shown(names: list[str]) -> str:
    return ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def record_files(folder: Path, kind: str) -> None:
    """List every file now in ``folder`` as written by glarelab, as output of ``kind``.

    Parameters
    ----------
    folder
        The folder whose listing (``.glarelab-files.json``) is written anew: every file and
        symbolic link under it, at any depth.
    kind
        The kind of output the listing records the files as (``'stimulus set'``, ``'report'``,
        ``'power'``, ...): an output replaces or overwrites only files of its own kind.
    """
    entries = _entries(folder)
    hashes = {entry: _sha256(folder / entry) for entry in entries}
    _write_listing(
        folder,
        dict.fromkeys(entries, kind),
        {entry: digest for entry, digest in hashes.items() if digest is not None},
    )


def edited_since(folder: Path, name: str) -> bool:
    """Whether the file ``name`` of ``folder`` was edited since glarelab wrote it there (its
    content recorded, :func:`record_written`, and now other).

    Parameters
    ----------
    folder
        The folder.
    name
        The file, relative to ``folder``.

    Returns
    -------
    bool
        True for a file whose recorded content differs from what it holds now.
    """
    written = _hashes(Path(folder))
    path = Path(folder) / name
    return name in written and path.exists() and _sha256(path) != written[name]


def claim_files(folder: Path, names: Iterable[str], kind: str, *, force: bool = False) -> None:
    """Before writing ``names`` into a shared ``folder``: refuse if one exists and glarelab did
    not write it there; otherwise list them as glarelab's. A name with no file yet is listed
    as unwritten until :func:`record_written` records it: should its write fail, a file saved
    under that name later is not taken for glarelab's.

    Parameters
    ----------
    folder
        The shared folder; it must exist.
    names
        The files about to be written, relative to ``folder``.
    kind
        The kind of output the listing records the files as (``'stimulus set'``, ``'report'``,
        ``'power'``, ...): an output replaces or overwrites only files of its own kind.
    force
        Whether to overwrite a listed file edited since glarelab wrote it (``--force``);
        default False.

    Raises
    ------
    ValueError
        Naming the first existing file the listing does not hold, or one edited since.
    """
    folder = Path(folder)
    with _listing_held(folder):
        _claim_held(folder, list(names), kind, force=force)


def _claim_held(folder: Path, names: list[str], kind: str, *, force: bool) -> None:
    """:func:`claim_files`'s checks and listing, the folder's listing held by the caller."""
    listed, written = _listing(folder), _hashes(folder)
    for name in names:
        path = folder / name
        if (path.exists() or path.is_symlink()) and name not in listed:
            raise ValueError(
                f"{path} exists and glarelab did not write it there; {kind} would "
                "overwrite it, so give another folder or move the file (nothing was changed)"
            )
        if not force and name in written and path.exists() and _sha256(path) != written[name]:
            raise ValueError(
                f"{path} was edited since glarelab wrote it; {kind} would overwrite it, so "
                "copy what you changed elsewhere, remove the file, or give another folder "
                "(nothing was changed)"
            )
    # listed anew with every name claimed before, written or not: the filtered listing
    # above dropped another output's name written but not yet recorded (psf's image
    # beside its axes), and a second run then took its own image for a user's
    every = _listing(folder, unwritten=True)
    _write_listing(folder, every | dict.fromkeys(names, kind), _claimed_hashes(folder, names))


@contextlib.contextmanager
def files_claimed(
    folder: Path, names: Iterable[str], kind: str, *, force: bool = False, created: bool = False
) -> Iterator[None]:
    """:func:`claim_files` for the work in the ``with`` block; should it be refused or fail,
    the folder's listing is left as the work found it: the names still without a file leave
    it, a file the work did not touch keeps the content recorded before, one it wrote is
    recorded as written. The listing goes if it then lists nothing, and ``folder`` too if
    the command made it (``created``) and it is empty.

    Parameters
    ----------
    folder, names, kind, force
        As for :func:`claim_files`.
    created
        Whether the command made ``folder`` for these files; default False.
    """
    folder = Path(folder)
    names = list(names)
    with _listing_held(folder):  # what the work finds, read as it is claimed
        recorded = _hashes(folder)
        found = {name: _sha256(folder / name) for name in names}
        _claim_held(folder, names, kind, force=force)
    try:
        yield
    except BaseException:
        with _listing_held(folder):
            files, hashes = _listing(folder, unwritten=True), _hashes(folder)
            for name in names:
                now = _sha256(folder / name)
                if not ((folder / name).exists() or (folder / name).is_symlink()):
                    files.pop(name, None)
                    hashes.pop(name, None)
                elif now != found[name] and now is not None:  # written before the failure
                    hashes[name] = now
                elif name in recorded:  # as it was: its content as recorded before
                    hashes[name] = recorded[name]
                else:
                    hashes.pop(name, None)
            if files:
                _write_listing(folder, files, hashes)
            else:
                with contextlib.suppress(FileNotFoundError):
                    (folder / LISTING).unlink()
        if created and not files:
            with contextlib.suppress(OSError):  # not empty: something else was made there
                folder.rmdir()
        raise


def record_written(folder: Path, names: Iterable[str]) -> None:
    """After a command wrote ``names`` into a shared ``folder``: record their content, so a
    later run refuses to overwrite one edited since (:func:`claim_files`).

    Parameters
    ----------
    folder
        The shared folder.
    names
        The files just written, relative to ``folder`` (listed by :func:`claim_files`).
    """
    folder = Path(folder)
    with _listing_held(folder):
        hashes = _hashes(folder)
        for name in names:
            digest = _sha256(folder / name)
            if digest is not None:
                hashes[name] = digest
        _write_listing(folder, _listing(folder, unwritten=True), hashes)


def _hashes_but(folder: Path, names: Iterable[str]) -> dict[str, str]:
    """The recorded content of the listed files, but for ``names`` (about to be written anew,
    their content not recorded)."""
    names = set(names)
    return {name: digest for name, digest in _hashes(folder).items() if name not in names}


def listed_files(folder: Path) -> dict[str, str]:
    """``{relative path: kind}`` of the files glarelab wrote into ``folder`` (empty if none).

    Parameters
    ----------
    folder
        The folder whose listing is read; a missing or unreadable listing lists nothing.

    Returns
    -------
    dict of str to str
        Each listed file's path relative to ``folder`` (``/``-separated), and its kind.
    """
    return _listing(Path(folder))


def list_files(folder: Path, names: Iterable[str], kind: str) -> None:
    """List ``names`` in ``folder`` as written by glarelab (checked by the caller).

    Parameters
    ----------
    folder
        The folder; it must exist. Files listed there before stay listed.
    names
        The files to add to the listing, relative to ``folder``; no check that glarelab
        wrote them (:func:`claim_files` checks first). A name with no file yet is listed as
        unwritten until :func:`record_written` records it, as :func:`claim_files` does.
    kind
        The kind of output the listing records the files as (``'stimulus set'``, ``'report'``,
        ``'power'``, ...): an output replaces or overwrites only files of its own kind.
    """
    folder = Path(folder)
    names = list(names)
    with _listing_held(folder):
        _write_listing(
            folder,
            _listing(folder, unwritten=True) | dict.fromkeys(names, kind),
            _claimed_hashes(folder, names),
        )


LISTING_WAIT_S = 60.0  # how long a process waits for another's update of a folder's listing


@contextlib.contextmanager
def _listing_held(folder: Path):
    """Hold a folder's listing while it is read, changed and written: processes writing into
    one folder at once (four ``calibrate fit`` to one ``--out``) each add their files, where
    the last write would otherwise keep only its own."""
    with waiting_for(
        folder / LISTING_LOCK,
        wait_s=LISTING_WAIT_S,
        poll_s=0.01,
        what=f"{folder / LISTING} (nothing was written)",
    ):
        yield


def _write_listing(
    folder: Path, files: dict[str, str], hashes: dict[str, str] | None = None
) -> None:
    """Write ``folder``'s listing: each file's kind, and the sha256 of the content glarelab
    wrote where known (a whole-folder output is refused over a file edited since)."""
    listing: dict = {"written_by": "glarelab", "files": dict(sorted(files.items()))}
    if hashes:
        listing["sha256"] = dict(sorted(hashes.items()))
    path = folder / LISTING
    if path.is_dir() or (path.exists() and not path.is_file()):
        raise ValueError(
            f"{path} is not a file (a folder?): glarelab keeps the list of the files it wrote "
            f"into {folder} under that name; move it away"
        )
    write_text(path, json.dumps(listing, indent=1) + "\n")


def output_lock(
    out: str | Path, kind: str, *, what: str | None = None, suffix: str = "output"
) -> ProcessLock:
    """The lock of a folder one process makes whole at a time (a stimulus set, a report, a
    power run): a file ``.NAME.SUFFIX.lock`` beside it (the folder itself is swapped). Two
    builds into one ``--out`` at once would each end "done" while the later replaced the
    other's output; the second is refused instead, naming the first.

    Parameters
    ----------
    out
        The folder (``--out``), as the user gave it (named in the refusal).
    kind
        What holds it, for the refusal (``'stimulus set build'``, ``'analysis'``, …).
    what
        What the folder is, for a refusal of a path with a loop of symbolic links on its way
        (``'stimulus set'``, ``'report'``); default ``kind``.
    suffix
        The lock file's kind, ``output`` unless an output kept its own name.

    Returns
    -------
    glarelab.files.locks.ProcessLock
        Not yet held; held, it refuses a second holder with a ``ValueError`` naming ``out``,
        the holder and what to do. A folder in which no lock can be made is refused with a
        ``ValueError`` too.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> with output_lock(folder / "report", "analysis"):
    ...     sorted(p.name for p in folder.iterdir())
    ['.report.output.lock']
    """
    final = without_link_loop(out, what=what or kind).resolve()

    def refusal(holder: str) -> ValueError:
        return ValueError(
            f"{out} is in use by another glarelab {kind} ({holder}): wait for it to end, "
            "or give another --out (nothing was changed)"
        )

    name = short_name(final.name, room=len(f"..{suffix}.lock") + 1)
    return _OutputLock(final.parent / f".{name}.{suffix}.lock", refusal=refusal, out=out)


class _OutputLock(ProcessLock):
    """:class:`ProcessLock` whose folder refusing a file is named as ``--out``'s."""

    def __init__(self, path: Path, *, refusal, out: str | Path):
        super().__init__(path, refusal=refusal)
        self.out = out
        self._made: list[Path] = []  # the folders made for the lock, innermost first

    def acquire(self) -> None:
        # removed on release if the work left them empty
        self._made = [p for p in [self.path.parent, *self.path.parent.parents] if not p.exists()]
        try:
            super().acquire()
        except OSError as error:  # a read-only or virtual parent: named by --out
            self._remove_made()
            raise ValueError(
                f"--out {self.out}: no file can be made in {self.path.parent} "
                f"({error.strerror}); give another --out"
            ) from None

    def release(self) -> None:
        super().release()
        self._remove_made()

    def _remove_made(self) -> None:
        for folder in self._made:
            try:
                folder.rmdir()
            except OSError:  # the work wrote there: kept, and so are its parents
                break
        self._made = []


def _aside_stem(final: Path) -> str:
    """The part of ``final``'s name in the names of its staging and replaced folders,
    ``.STEM.building-PID`` and ``.STEM.old-PID``: short enough for them to be legal."""
    return short_name(final.name, room=len("..building-") + 10)


def _leftovers(final: Path) -> None:
    """Remove the staging and replaced folders of ``final`` that killed processes left, and
    put back an earlier ``final`` that a process killed between two renames left aside."""
    for kind in ("old", "building"):
        pattern = f".{glob_escape(_aside_stem(final))}.{kind}-*"
        for leftover in sorted(final.parent.glob(pattern)):
            pid = leftover.name.rsplit("-", 1)[-1]
            if not pid.isdigit() or int(pid) == os.getpid() or _alive(int(pid)):
                continue
            if kind == "old" and not final.exists() and not final.is_symlink():
                with contextlib.suppress(FileNotFoundError):  # another process put it back
                    leftover.rename(final)  # the earlier output, complete
            else:
                shutil.rmtree(leftover, ignore_errors=True)


def restore_folder(final: str | Path) -> None:
    """Put back a ``final`` that a process killed between the two renames of
    :func:`replace_folder` left aside, and remove the folders killed builds left beside it.

    Call it before reading or writing into a folder that is replaced whole while files in it
    are kept (:func:`staging_folder` calls it too): on a file system that cannot swap two
    folders in one step, ``final`` is missing until then.

    Parameters
    ----------
    final
        The folder that is replaced whole; nothing happens if its parent does not exist.
    """
    final = Path(final).resolve()
    if final.parent.is_dir():
        _leftovers(final)


def staging_folder(final: Path) -> Path:
    """A new, empty folder next to ``final`` to build its replacement in.

    Parameters
    ----------
    final
        The folder the build will replace (:func:`replace_folder`); its parent folders are
        created. Leftovers of killed builds beside it are cleared first
        (:func:`restore_folder`).

    Returns
    -------
    pathlib.Path
        ``.NAME.building-PID`` beside ``final``, empty.

    Raises
    ------
    ValueError
        When no folder can be made beside ``final`` (a read-only or virtual file system such
        as ``/proc``), naming ``final``, not the temporary name.
    """
    final = Path(final).resolve()
    final.parent.mkdir(parents=True, exist_ok=True)
    _leftovers(final)
    staging = final.with_name(f".{_aside_stem(final)}.building-{os.getpid()}")
    shutil.rmtree(staging, ignore_errors=True)  # a build of this process that was cut short
    try:
        staging.mkdir()
    except OSError as error:  # named by the output asked for, not the temporary name
        raise ValueError(
            f"--out {final}: no folder can be made in {final.parent} ({error.strerror}); "
            "give another --out"
        ) from None
    return staging


RENAME_EXCHANGE = 2  # linux/fs.h: swap two paths in one step


def _exchange(first: Path, second: Path) -> bool:
    """Swap two existing paths atomically (Linux ``renameat2``); False where unsupported."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError, TypeError):
        return False
    at_cwd = -100
    result = renameat2(at_cwd, os.fsencode(first), at_cwd, os.fsencode(second), RENAME_EXCHANGE)
    if result == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP):
        return False
    raise OSError(code, os.strerror(code), str(second))


def replace_folder(
    staging: Path, final: Path, *, kind: str, files: Iterable[str] | None = None
) -> None:
    """List the finished ``staging`` folder's files and move it to ``final`` in one step (the
    two folders are swapped atomically where the system can; elsewhere the earlier ``final``
    is moved aside first and put back by the next build if the process dies in between). The
    earlier ``final`` is removed only once the new one is in place.

    Parameters
    ----------
    staging
        The finished build (:func:`staging_folder`); it is gone afterwards.
    final
        The folder it replaces; it need not exist.
    kind
        The kind of output the listing records the files as (``'stimulus set'``, ``'report'``,
        ``'power'``, ...): an output replaces or overwrites only files of its own kind.
    files
        The files glarelab wrote, relative to ``staging``, for the listing where the folder
        holds others too; default ``None``: every file in ``staging``.

    Raises
    ------
    OSError
        If the folders cannot be swapped or renamed (the earlier ``final`` is then kept, or
        put back by the next build).
    """
    if files is None:
        record_files(staging, kind)
    else:
        _write_listing(staging, {name: kind for name in files if (staging / name).is_file()})
    for root, _, files in os.walk(staging):
        for name in files:
            with contextlib.suppress(OSError):
                handle = os.open(Path(root) / name, os.O_RDONLY)
                try:
                    os.fsync(handle)
                finally:
                    os.close(handle)
        fsync_folder(root)
    final = Path(final).resolve()
    for _attempt in range(5):  # another process may put its own output there meanwhile
        if final.is_dir() and not final.is_symlink() and _exchange(staging, final):
            fsync_folder(final.parent)
            _remove_earlier(staging, final, kind)  # staging is now the earlier output
            return
        old = None
        if final.exists():
            old = final.with_name(f".{_aside_stem(final)}.old-{os.getpid()}")
            shutil.rmtree(old, ignore_errors=True)
            try:
                final.rename(old)
            except FileNotFoundError:  # moved by another process: look again
                continue
        try:
            staging.rename(final)
        except OSError as error:  # another process's output arrived first: replace it
            if old is not None and not final.exists():
                with contextlib.suppress(OSError):
                    old.rename(final)  # put the earlier output back
            elif old is not None:
                shutil.rmtree(old, ignore_errors=True)
            if error.errno in (errno.EEXIST, errno.ENOTEMPTY) and final.is_dir():
                continue
            raise
        fsync_folder(final.parent)
        if old is not None:
            _remove_earlier(old, final, kind)
        return
    raise OSError(errno.EBUSY, "other processes kept replacing the folder", str(final))


def _same_entry(first: Path, second: Path) -> bool:
    """Whether two paths are one file (hard links) or two symbolic links to one target."""
    try:
        if first.is_symlink() or second.is_symlink():
            both = first.is_symlink() and second.is_symlink()
            return both and os.readlink(first) == os.readlink(second)
        return os.path.samefile(first, second)
    except OSError:
        return False


def _remove_earlier(earlier: Path, final: Path, kind: str) -> None:
    """Remove the output ``final`` replaced, once the files a person saved into it while the
    new one was made (files glarelab did not write there, or edited since) are moved into
    ``final``, at their own paths (``NAME.kept`` where the new output has a file of that
    name); the command's start had checked the folder, but a note saved during a minutes-long
    build was deleted with it. Where one cannot be moved, the earlier folder is kept beside
    ``final`` as ``NAME.kept-PID``. Either way a warning names them."""
    listed, written = _listing(earlier), _hashes(earlier)
    moved, failed = [], False
    for entry in _entries(earlier):
        source = earlier / entry
        if listed.get(entry) == kind and (
            entry not in written or _sha256(source) == written[entry]
        ):
            continue  # glarelab's, as written: replaced by the new output
        target = final / entry
        if target.exists() or target.is_symlink():
            if _same_entry(source, target):
                continue  # the same file (or link), carried into the new output
            number, stem = 1, target.name + ".kept"
            target = target.with_name(stem)
            while target.exists() or target.is_symlink():
                number += 1
                target = target.with_name(f"{stem}-{number}")
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            source.rename(target)
        except OSError:
            failed = True
            continue
        moved.append(target.relative_to(final).as_posix())
    if failed:
        kept = final.with_name(f"{final.name}.kept-{os.getpid()}")
        try:
            earlier.rename(kept)
        except OSError:
            kept = earlier
        warnings.warn(
            f"{final}: files saved into it while the new {kind} was made could not all be "
            f"moved into it; the earlier folder is kept as {kept}",
            stacklevel=3,
        )
        return
    shutil.rmtree(earlier, ignore_errors=True)
    if moved:
        warnings.warn(
            f"{final}: {len(moved)} file(s) saved into it while the new {kind} was made were "
            f"kept in it: {', '.join(moved[:5])}{' ...' if len(moved) > 5 else ''}",
            stacklevel=3,
        )
