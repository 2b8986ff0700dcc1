"""Writing session data so that nothing collected is ever lost.

A session's files share one stem, ``PARTICIPANT_STUDY_sN_YYYY-MM-DD_HHMM`` (the date and time the
session first started, as PsychoPy names its data files; ``_pilot`` follows for a pilot run):
the CSV, one row per trial, written, flushed and fsync'ed the moment the trial ends; the JSON
sidecar (who, what, how, when), rewritten atomically whenever the session's state changes; the
PsychoPy log (``.log``) and the
frame intervals (``_frames.tsv``) of sessions run on a screen.

A session is held by one process at a time: an exclusive lock on a small lock file (which
names the holder's process id) is taken before any file is looked at, so a second process that
starts or resumes the same session is refused. A participant's session on a screen is locked
across output folders (``PARTICIPANT_STUDY_sN.lock`` in :func:`lock_folder`): the same
participant's session run twice into two ``--out`` folders is refused too; simulated sessions,
which power analyses run by the thousand in folders of their own, lock their folder only
(``.PARTICIPANT_STUDY_sN.lock`` in it). A new
session refuses when any file of that participant, study and session number exists; its CSV
header is written and fsync'ed before the first trial, and a session whose files cannot be
written (a full disk) leaves no file behind. ``resume`` appends to the existing CSV after
checking its header.

A disk that fills during a session must not leave its sidecar saying ``running``: with its
header the session sets aside :data:`RESERVE_BYTES` on the same disk (a hidden
``.STEM.reserve`` file, removed when the session ends), and gives them back when a write fails,
so that the sidecar and the log can still say how and why it ended
(:meth:`SessionFiles.release_reserve`); the session then stops with :class:`WriteFault`.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import re
import sys
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from glarelab.files.inputs import loads_json
from glarelab.files.locks import ProcessLock
from glarelab.protocols import columns, format_value, row_digest

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = [
    "RESERVE_BYTES",
    "SessionError",
    "SessionFiles",
    "SessionLock",
    "WriteFault",
    "check_session_id",
    "lock_folder",
    "read_rows",
    "session_files",
    "tracker_store_name",
]

_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}\Z")  # \Z: "$" admits a final newline


RESERVE_BYTES = 256 * 1024  # room for a session's last sidecar and log lines on a full disk


class SessionError(ValueError):
    """A session that may not start or resume; nothing was written."""


class WriteFault(RuntimeError):
    """A session stopped because its files could not be written (a full disk, a storage that
    went away): every trial recorded before is on disk, and the sidecar says why it ended."""


# ids R's read.csv (its na.strings, "NA") or pandas' read_csv (its default na_values that
# an id may spell) read back as a missing value
MISSING_IDS = frozenset({"NA", "NaN", "nan", "null", "NULL", "None"})


def check_session_id(participant: str, session: int) -> None:
    """Refuse a participant id that is not file-name safe, or a session number below 1.

    Parameters
    ----------
    participant
        The participant's id: 1-64 letters, digits, ``_`` or ``-``, starting with a letter or
        digit (it names the session's files), not one R or pandas reads as missing
        (:data:`MISSING_IDS`).
    session
        The session's number, an integer >= 1.

    Raises
    ------
    SessionError
        Naming the value and what is allowed.
    """
    if not isinstance(participant, str) or not _ID.match(participant):
        raise SessionError(
            "participant must be 1-64 letters, digits, '_' or '-', starting with a letter "
            f"or digit; got {participant!r}"
        )
    if participant in MISSING_IDS:
        raise SessionError(
            f"participant {participant!r} reads back as a missing value in R (read.csv) and "
            "pandas, so the participant would drop out of the analysis there; give another id"
        )
    if isinstance(session, bool) or not isinstance(session, int) or session < 1:
        raise SessionError(f"session must be an integer >= 1; got {session!r}")


def _prefix(participant: str, study: str, session: int) -> str:
    return f"{participant}_{study}_s{session}"


def tracker_store_name(stem: str, run: int) -> str:
    """The file of ioHub's hdf5 store for one run of a session: ``STEM_iohub.hdf5`` for the
    first, ``STEM_iohub_runN.hdf5`` for a resumed run N.

    ioHub opens its store for writing anew (its ``multiple_sessions`` setting, which
    ``launchHubServer`` cannot set, is false), so a resumed run given the first run's store
    would erase its raw samples; a killed run's store is never opened again either.

    Parameters
    ----------
    stem
        The session's file name without ``.csv``.
    run
        The run's number (1 for the session's first).

    Returns
    -------
    str
        The store's file name.

    Raises
    ------
    ValueError
        For a run below 1.

    Examples
    --------
    >>> tracker_store_name("P01_luidolt2020-live_s1_2026-12-03_2100", 1)
    'P01_luidolt2020-live_s1_2026-12-03_2100_iohub.hdf5'
    >>> tracker_store_name("P01_luidolt2020-live_s1_2026-12-03_2100", 2)
    'P01_luidolt2020-live_s1_2026-12-03_2100_iohub_run2.hdf5'
    """
    if isinstance(run, bool) or not isinstance(run, int) or run < 1:
        raise ValueError(f"run must be a whole number >= 1, got {run!r}")
    return f"{stem}_iohub.hdf5" if run == 1 else f"{stem}_iohub_run{run}.hdf5"


def session_files(out: Path, participant: str, study: str, session: int) -> list[Path]:
    """Every file of one participant's session of a study in ``out`` (whatever its date).

    Parameters
    ----------
    out
        The data folder.
    participant
        The participant's id.
    study
        The study's name.
    session
        The session's number.

    Returns
    -------
    list of pathlib.Path
        The session's CSV, sidecar, log, frame times and ioHub's store and log, sorted;
        empty for a missing folder.

    Raises
    ------
    SessionError
        For a participant id or session number that is not allowed.
    """
    check_session_id(participant, session)
    pattern = re.compile(
        re.escape(_prefix(participant, study, session))
        + r"_\d{4}-\d{2}-\d{2}_\d{4}(_pilot)?"
        + r"(\.csv|\.json|\.log|_frames\.tsv|_iohub(_run[1-9]\d*)?\.hdf5|_iohub\.log)\Z"
    )
    folder = Path(out)
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.iterdir() if pattern.match(p.name))


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of a session CSV as strings (a partly written last line is ignored).

    Parameters
    ----------
    path
        The session CSV.

    Returns
    -------
    list of dict of str to str
        One dict per complete row, column → cell.
    """
    text = Path(path).read_text(encoding="utf-8")
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]  # a row cut by a crash is not a trial
    return list(csv.DictReader(io.StringIO(text)))


def _check_trial_sequence(path: Path, rows: list[dict[str, str]]) -> None:
    """A resumed CSV's trials run 1, 2, 3, … once each (rows a spreadsheet sorted are put in
    trial order first): a gap means rows were deleted, a repeat a row pasted twice, and
    resuming would record a trial twice or skip one.

    Raises
    ------
    SessionError
        Naming the line and the trial number that breaks the sequence.
    """
    previous = 0
    for line, row in enumerate(rows, start=2):
        value = row.get("trial", "")
        trial = _trial_number(value)
        if trial is not None and trial == previous:
            raise SessionError(
                f"{path}, line {line}: trial {trial} is there twice (a row pasted twice?); each "
                "trial has "
                "one row, and resuming would count the copy as a trial done: delete the copy "
                "and resume, or keep the file for the record and start a new session number"
            )
        if trial is None or trial != previous + 1:
            raise SessionError(
                f"{path}, line {line}: trial {value!r} after trial {previous} (expected "
                f"{previous + 1}): rows were deleted, so resuming would record a trial "
                "twice; keep the file for the record and start a new session number"
            )
        previous = trial


def _trial_number(value) -> int | None:
    """A row's trial number, or None for a cell that is not a whole number >= 1."""
    try:
        trial = int(value)
    except (TypeError, ValueError):
        return None
    return trial if trial >= 1 else None


def _in_trial_order(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    """``rows`` sorted by trial when they hold each of trials 1 … n once (a spreadsheet's
    sort, which the analysis reads too); otherwise as they are, for the sequence check to
    name what is wrong."""
    numbers = [_trial_number(row.get("trial")) for row in rows]
    if None in numbers or sorted(numbers) != list(range(1, len(rows) + 1)):
        return rows
    return [row for _, row in sorted(zip(numbers, rows, strict=True), key=lambda p: p[0])]


def _check_no_blank_line(path: Path, data: bytes) -> None:
    """A blank line in a session CSV (an editor's, or ``echo >>``) is refused by the analysis:
    a resume would append after it and complete a file that cannot be analysed.

    Raises
    ------
    SessionError
        Naming the first blank line.
    """
    lines = data.split(b"\n")
    for number, line in enumerate(lines[1:], start=2):
        last = number == len(lines)
        if not line.strip(b" \t\r") and (line or not last):
            raise SessionError(
                f"{path}, line {number} is blank (added by an editor?): the analysis refuses a "
                "blank line, so the session is not resumed with it; delete the line and resume"
            )


def _header_problem(first: str, names: list[str], study: str) -> str:
    """What is wrong with a resumed CSV's first line, in words."""
    if first.startswith("\ufeff"):
        return (
            "it starts with a byte-order mark (saved again by a spreadsheet or editor); the "
            "session appends rows to the file as written"
        )
    if first.endswith("\r"):
        return (
            "its lines end in CR LF (saved again by a Windows editor or a spreadsheet); the "
            "session appends rows to the file as written"
        )
    if sorted(first.split(",")) == sorted(names):
        return (
            "its columns are in another order than the session writes them (moved in a "
            "spreadsheet?): rows appended now would not match the header"
        )
    return f"it has no valid {study} header"


def _check_unended_row(path: Path, data: bytes, n_columns: int, n_rows: int) -> None:
    """A last line without its newline is a row cut by a crash (fewer cells: dropped on
    resume) or a whole row an editor saved without one; the two cannot be told apart when the
    cut fell inside the last cell (a time, a comment), so a last line with every cell is
    left to the person rather than deleted or guessed.

    Raises
    ------
    SessionError
        If the last line lacks its newline but has the header's number of cells.
    """
    if not data or data.endswith(b"\n"):
        return
    tail = data[data.rfind(b"\n") + 1 :].decode("utf-8", "replace")
    try:
        cells = next(csv.reader([tail]), [])
    except csv.Error:
        return  # a quote left open: cut inside a quoted cell
    if len(cells) < n_columns:
        return
    raise SessionError(
        f"{path}, line {n_rows + 2}: the last row has no final newline: it is whole (saved by "
        "an editor) or cut by a crash inside its last cell, which the file cannot tell; check "
        "it, then end it with a newline to keep it or delete the line to run that trial again; "
        "nothing was changed"
    )


def _fsync_folder(folder: Path) -> None:
    if sys.platform == "win32":  # pragma: no cover - folders cannot be opened there
        return
    descriptor = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


LOCKS_ENV = "GLARELAB_LOCKS"


def lock_folder() -> Path:
    """Where the locks of participants' sessions are kept, whatever their output folder:
    ``$GLARELAB_LOCKS``, or ``locks`` in the user's state folder (platformdirs: on Linux
    ``~/.local/state/glarelab/locks``)."""
    if os.environ.get(LOCKS_ENV):
        return Path(os.environ[LOCKS_ENV])
    from platformdirs import user_state_dir

    return Path(user_state_dir("glarelab")) / "locks"


class SessionLock(ProcessLock):
    """An exclusive, non-blocking lock on one participant's session of a study
    (:class:`glarelab.files.locks.ProcessLock`): the operating system releases it when the
    process ends, however it ends, so a killed session never leaves a stale lock.

    Parameters
    ----------
    out, participant, study, session
        The session and its output folder.
    across_folders
        Lock the session whatever its output folder (in :func:`lock_folder`); otherwise in
        ``out`` only.
    """

    def __init__(
        self,
        out: Path,
        participant: str,
        study: str,
        session: int,
        *,
        across_folders: bool = False,
    ):
        check_session_id(participant, session)
        what = f"participant {participant!r}'s {study} session {session}"
        name = _prefix(participant, study, session)
        path = lock_folder() / f"{name}.lock" if across_folders else Path(out) / f".{name}.lock"
        self.what = what
        super().__init__(
            path,
            refusal=lambda holder: SessionError(
                f"{what} is in use by another process ({holder}; lock file {path}): "
                "one session is run by one process at a time, whatever its output folder"
                if across_folders
                else f"{what} is in use by another process ({holder}; lock file {path}): "
                "one session is run by one process at a time"
            ),
        )


class SessionFiles:
    """The files of one session, held under its lock until :meth:`close`.

    Creating the object takes the lock and checks the session's files without writing
    anything (a new session: none may exist; a resumed one: its CSV must exist with this
    format's header); :meth:`open` then creates the CSV with its header (fsync'ed) or opens it
    for appending.

    Parameters
    ----------
    protocol, participant, session, out
        Which study (its protocol sets the CSV's columns) and session, and the folder.
    resume
        Continue the existing session; otherwise start a new one.
    started
        When this run started (names a new session's files).
    pilot
        Whether the session is a pilot run (``--pilot``): its files' names end in
        ``_pilot``, and it resumes only as a pilot; default False.
    lock
        The session's lock, held already (:class:`SessionLock`, taken before the stimulus set
        is verified); default: the lock of ``out``, taken now.

    Raises
    ------
    SessionError
        The session is held by another process, has data (new) or none (resume), or its CSV
        cannot be resumed; nothing was written.
    """

    def __init__(
        self,
        protocol: Protocol,
        participant: str,
        session: int,
        out: Path,
        *,
        resume: bool,
        started: datetime,
        pilot: bool = False,
        lock: SessionLock | None = None,
    ):
        study = protocol.study
        self.study = study
        self.resume = resume
        self.columns = columns(protocol)
        self.names = [c.name for c in self.columns]
        out = Path(out)
        self.out = out
        self._made_out = not out.exists()  # removed again if the session leaves nothing in it
        if lock is None:
            lock = SessionLock(out, participant, study, session)
            lock.acquire()
        self.lock = lock
        self._fd: int | None = None  # the CSV, written unbuffered: a row is on disk or not at all
        self.created = False
        self.rows: list[dict[str, str]] = []
        try:
            existing = session_files(out, participant, study, session)
            if resume:
                self.csv_path = self._existing_csv(existing, out, participant, study, session)
                was_pilot = self.csv_path.stem.endswith("_pilot")
                if was_pilot != pilot:
                    raise SessionError(
                        f"{self.csv_path.name} is {'a pilot' if was_pilot else 'a real'} "
                        f"session: resume it {'with' if was_pilot else 'without'} --pilot"
                    )
            elif existing:
                raise SessionError(
                    f"{existing[0]} exists: participant {participant!r} session {session} "
                    "already has data; use another session number, or --resume to continue it"
                )
            else:
                stem = f"{_prefix(participant, study, session)}_{started:%Y-%m-%d_%H%M}"
                stem += "_pilot" if pilot else ""  # a pilot's files say so in their names
                self.csv_path = out / f"{stem}.csv"
        except BaseException:
            self.close()
            raise
        stem = self.csv_path.name.removesuffix(".csv")
        self.reserve_path = out / f".{stem}.reserve"
        self.sidecar_path = self.csv_path.with_suffix(".json")
        self.log_path = self.csv_path.with_suffix(".log")
        self.frames_path = out / f"{stem}_frames.tsv"

    def _existing_csv(self, existing, out, participant, study, session) -> Path:
        csvs = [p for p in existing if p.suffix == ".csv"]
        if not csvs:
            raise SessionError(
                f"nothing to resume: no file {_prefix(participant, study, session)}_*.csv in {out}"
            )
        if len(csvs) > 1:
            raise SessionError(
                f"several files of participant {participant!r}'s {study} session {session}: "
                f"{', '.join(p.name for p in csvs)}; move all but one away to resume"
            )
        path = csvs[0]
        data = path.read_bytes()
        first = data.split(b"\n", 1)[0].decode("utf-8", "replace")
        if b"\n" not in data or first != ",".join(self.names):
            found = "an empty file" if not data else f"first line {first[:80]!r}"
            what = _header_problem(first, self.names, study)
            raise SessionError(
                f"{path}: {what} ({found}): it cannot be resumed as it is; restore the file "
                f"as the session wrote it, or keep it for the record and start a new session "
                "number"
            )
        _check_no_blank_line(path, data)
        self.rows = _in_trial_order(read_rows(path))
        _check_trial_sequence(path, self.rows)
        _check_unended_row(path, data, len(self.names), len(self.rows))
        return path

    def open(self) -> None:
        """Create the new session's CSV with its header, or open the resumed one to append.

        Raises
        ------
        SessionError
            If the CSV cannot be written (a full disk); a new session leaves no file.
        """
        if self.resume:
            data = self.csv_path.read_bytes()
            if not data.endswith(b"\n"):  # a row cut by a crash is not a trial
                with self.csv_path.open("r+b") as handle:
                    handle.truncate(data.rfind(b"\n") + 1)
            self._fd = os.open(self.csv_path, os.O_RDWR | os.O_APPEND)
            try:
                self._reserve()
            except OSError as error:
                os.close(self._fd)
                self._fd = None
                raise SessionError(
                    f"could not set aside {RESERVE_BYTES // 1024} KiB next to "
                    f"{self.csv_path} ({error.strerror or error}): the disk is (nearly) full; "
                    "the session was not resumed and is as it was"
                ) from None
            return
        self.out.mkdir(parents=True, exist_ok=True)
        self._fd = os.open(self.csv_path, os.O_RDWR | os.O_APPEND | os.O_CREAT | os.O_EXCL, 0o644)
        self.created = True
        try:
            self._write_line(self.names)
            self._reserve()
        except OSError as error:
            self.discard()
            raise SessionError(
                f"could not write {self.csv_path} ({error.strerror or error}); the session "
                "did not start and left no file"
            ) from None

    def _reserve(self) -> None:
        """Set aside :data:`RESERVE_BYTES` on the session's disk (written, not sparse)."""
        descriptor = os.open(self.reserve_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        try:
            os.write(descriptor, b"\0" * RESERVE_BYTES)
            os.fsync(descriptor)
        except OSError:
            self.release_reserve()
            raise
        finally:
            os.close(descriptor)

    def release_reserve(self) -> None:
        """Give the room set aside back to the disk (a write failed: the sidecar and the log
        can still be written)."""
        with contextlib.suppress(OSError):
            self.reserve_path.unlink(missing_ok=True)

    # --- writing ------------------------------------------------------------------------

    def _write_line(self, cells: list[str]) -> None:
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator="\n").writerow(cells)
        data = buffer.getvalue().encode("utf-8")
        size = os.fstat(self._fd).st_size
        try:
            written = 0
            while written < len(data):
                written += os.write(self._fd, data[written:])
            os.fsync(self._fd)
        except OSError:
            with contextlib.suppress(OSError):  # no half row: back to the last whole one
                os.ftruncate(self._fd, size)
            raise

    def write_row(self, row: dict) -> None:
        """Append one trial and make it durable before returning.

        Parameters
        ----------
        row
            Column → value of one trial (:func:`glarelab.protocols.columns.format_value` writes
            each); columns left out are empty, which only optional columns may be.

        Raises
        ------
        ValueError
            For a column the study's CSV does not have, or a required value missing.
        OSError
            If the CSV is no longer at its path (removed or replaced with its folder during
            the session): the trials it held are written back first (:meth:`check_in_place`).
        """
        unknown = set(row) - set(self.names)
        if unknown:
            raise ValueError(f"row has columns the {self.study} schema lacks: {sorted(unknown)}")
        cells = [format_value(row.get(c.name), c) for c in self.columns]
        self.check_in_place()
        self._write_line(cells)
        self.rows.append(dict(zip(self.names, cells, strict=True)))
        self.check_in_place()

    def row_digests(self) -> list[str]:
        """Each trial's :func:`~glarelab.protocols.row_digest`, trial 1 first: the sidecar's
        ``row_sha256``, against which the analysis checks the rows it counts."""
        return [row_digest(row[name] for name in self.names) for row in self.rows]

    def check_in_place(self) -> None:
        """The CSV this session appends to is still the file at its path.

        A CSV removed during the session (its folder deleted, a cleaning script) takes the
        trials with it while the open file still accepts rows; the trials held are written
        back (to the path, its folder made again, or beside it when another file took the
        name) before the session is stopped.

        Raises
        ------
        OSError
            Naming where the trials now are.
        """
        if self._fd is None:
            return
        try:
            same = os.path.samestat(os.fstat(self._fd), os.stat(self.csv_path))
        except FileNotFoundError:
            same = False
        if same:
            return
        size = os.fstat(self._fd).st_size
        data = os.pread(self._fd, size, 0)
        try:
            self.csv_path.parent.mkdir(parents=True, exist_ok=True)
            target = self.csv_path
            if target.exists() or target.is_symlink():
                target = target.with_name(f"{self.csv_path.stem}.rescued-{os.getpid()}.csv")
            descriptor = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            try:
                os.write(descriptor, data)
                os.fsync(descriptor)
            finally:
                os.close(descriptor)
        except OSError as error:
            raise OSError(
                error.errno,
                "the session's CSV was removed during the session and its trials could not be "
                f"written back ({error.strerror or error})",
                str(self.csv_path),
            ) from None
        raise OSError(
            2,
            "the session's CSV was removed or replaced during the session; its "
            f"{len(self.rows)} trials are written back to {target}",
            str(self.csv_path),
        )

    def write_sidecar(self, data: dict) -> None:
        """Rewrite the sidecar atomically (a crash leaves the previous version).

        Parameters
        ----------
        data
            The sidecar's content, JSON-serialisable (other values are written as text).
        """
        temporary = self.sidecar_path.with_suffix(".json.tmp")
        try:
            with temporary.open("w", encoding="utf-8") as handle:
                handle.write(json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")
                handle.flush()
                os.fsync(handle.fileno())
            os.replace(temporary, self.sidecar_path)
            _fsync_folder(self.sidecar_path.parent)
        except BaseException as error:  # a full disk, or a stop (SIGTERM) mid-write
            temporary.unlink(missing_ok=True)
            if isinstance(error, FileNotFoundError) and not self.sidecar_path.parent.is_dir():
                # the session's folder was removed: its trials are written back first, and
                # the error says where (the sidecar's write can come before the next row's)
                self.check_in_place()
            raise

    def read_sidecar(self) -> dict:
        if not self.sidecar_path.is_file():
            return {}
        try:
            data = loads_json(self.sidecar_path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError) as error:
            raise SessionError(f"{self.sidecar_path} is not valid JSON ({error})") from None
        if not isinstance(data, dict):
            raise SessionError(f"{self.sidecar_path} is not a JSON object")
        return data

    def discard(self) -> None:
        """Remove the files of a new session that could not start (no trial was run); a
        resumed session's files are never removed."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        self.release_reserve()
        if self.created and not self.rows:
            stem = self.csv_path.name.removesuffix(".csv")
            tracker = [self.out / tracker_store_name(stem, 1), self.out / f"{stem}_iohub.log"]
            for path in (
                self.csv_path,
                self.sidecar_path,
                self.sidecar_path.with_suffix(".json.tmp"),  # a write cut short by the stop
                self.log_path,
                self.frames_path,
            ):
                path.unlink(missing_ok=True)
            for path in tracker:
                path.unlink(missing_ok=True)
            self.created = False

    def close(self) -> None:
        """Close the CSV, give back the room set aside, release the lock; a folder this
        session made and left empty (it was refused, or stopped before its first write) is
        removed."""
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        if getattr(self, "reserve_path", None) is not None:
            self.release_reserve()
        self.lock.release()
        if self._made_out:
            with contextlib.suppress(OSError):  # not empty: it holds the session's files
                self.out.rmdir()
