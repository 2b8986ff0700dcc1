"""Writing session data so that nothing collected is ever lost.

One CSV per session, one row per trial, written, flushed and fsync'ed the moment the trial
ends; a JSON sidecar with who, what and how, rewritten atomically whenever the session's state
changes. A session file that exists is never overwritten: a new session refuses, ``resume``
appends to it.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
from pathlib import Path

from .schema import columns, format_value

__all__ = ["SessionFiles", "read_rows", "session_paths"]

_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


def session_paths(out: Path, study: str, participant: str, session: int) -> tuple[Path, Path]:
    """``(csv, sidecar)`` paths of a session; the participant id must be file-name safe."""
    if not _ID.match(participant):
        raise ValueError(
            f"participant must be 1-64 letters, digits, '_', '-' or '.', starting with a letter "
            f"or digit; got {participant!r}"
        )
    if session < 1:
        raise ValueError(f"session must be >= 1; got {session!r}")
    stem = f"{study}_{participant}_s{session}"
    return Path(out) / f"{stem}.csv", Path(out) / f"{stem}.json"


def read_rows(path: Path) -> list[dict[str, str]]:
    """The rows of a session CSV as strings (a partly written last line is ignored)."""
    text = Path(path).read_text(encoding="utf-8")
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]  # a row cut by a crash is not a trial
    return list(csv.DictReader(io.StringIO(text)))


class SessionFiles:
    """The CSV and sidecar of one session.

    Parameters
    ----------
    study, participant, session, out
        Which session, and the folder for its files.
    resume
        Continue an existing session (its CSV must exist); otherwise a new session, which
        refuses to start if its CSV or sidecar exists.
    """

    def __init__(self, study: str, participant: str, session: int, out: Path, *, resume: bool):
        self.study = study
        self.columns = columns(study)
        self.csv_path, self.sidecar_path = session_paths(out, study, participant, session)
        Path(out).mkdir(parents=True, exist_ok=True)
        if resume:
            if not self.csv_path.is_file():
                raise ValueError(f"nothing to resume: {self.csv_path} does not exist")
            self.rows = read_rows(self.csv_path)
            self._truncate_partial_line()
            self._handle = self.csv_path.open("a", encoding="utf-8", newline="")
        else:
            for path in (self.csv_path, self.sidecar_path):
                if path.exists():
                    raise ValueError(
                        f"{path} exists: participant {participant!r} session {session} already "
                        "has data; use another session number, or --resume to continue it"
                    )
            self.rows = []
            self._handle = self.csv_path.open("x", encoding="utf-8", newline="")
            self._write_line([c.name for c in self.columns])

    def _truncate_partial_line(self) -> None:
        data = self.csv_path.read_bytes()
        if data and not data.endswith(b"\n"):
            with self.csv_path.open("r+b") as handle:
                handle.truncate(data.rfind(b"\n") + 1)

    def _write_line(self, cells: list[str]) -> None:
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator="\n").writerow(cells)
        self._handle.write(buffer.getvalue())
        self._handle.flush()
        os.fsync(self._handle.fileno())

    def write_row(self, row: dict) -> None:
        """Append one trial and make it durable before returning."""
        unknown = set(row) - {c.name for c in self.columns}
        if unknown:
            raise ValueError(f"row has columns the {self.study} schema lacks: {sorted(unknown)}")
        cells = [format_value(row.get(c.name), c) for c in self.columns]
        self._write_line(cells)
        self.rows.append(dict(zip([c.name for c in self.columns], cells, strict=True)))

    def write_sidecar(self, data: dict) -> None:
        """Rewrite the sidecar atomically (a crash leaves the previous version)."""
        temporary = self.sidecar_path.with_suffix(".json.tmp")
        temporary.write_text(json.dumps(data, indent=2, sort_keys=True, default=str) + "\n")
        with temporary.open("rb") as handle:
            os.fsync(handle.fileno())
        os.replace(temporary, self.sidecar_path)

    def read_sidecar(self) -> dict:
        return json.loads(self.sidecar_path.read_text()) if self.sidecar_path.is_file() else {}

    def close(self) -> None:
        self._handle.close()
