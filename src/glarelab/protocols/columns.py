"""The session data format: one CSV per session, one row per trial, and a JSON sidecar.

Defined once, here, for the experiments that write it and the analysis that reads it. This
module imports nothing of the suite but the protocols and never PsychoPy.

Every CSV begins with the columns of :data:`COMMON`; the study's paradigm adds its own, derived
from the protocol (:func:`columns`). Types are one of
``str``, ``int``, ``float``, ``bool`` (written ``true``/``false``); an empty cell is a missing
value and is allowed only where the column says so (``optional=True``). ``since`` names the
data-format version that added a column: files written before it lack the column, and the
analysis reads them with the column missing (``counted`` as true).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from glarelab.protocols.core import Protocol

__all__ = [
    "COMMON",
    "DATA_FORMAT",
    "ROW_DIGESTS_SINCE",
    "Column",
    "columns",
    "format_value",
    "row_digest",
]

DATA_FORMAT = "0.5"  # the version of the session files written now (recorded in the sidecar)
# the data format from which a sidecar records each row's digest (row_sha256, row_digest)
ROW_DIGESTS_SINCE = "0.5"
ROW_DIGEST_HEX_DIGITS = 16  # of a row's sha256 kept in the sidecar (64 bits per row)


@dataclass(frozen=True)
class Column:
    """One CSV column: name, type, unit and meaning; ``choices`` limits a string column.

    Parameters
    ----------
    name
        The column's header in the CSV.
    kind
        The type of its values: ``str``, ``int``, ``float`` or ``bool`` (written
        ``true``/``false``).
    doc
        What the column holds, for ``docs/data.md``.
    unit
        The unit of a number (``'s'``, ``'cd/m²'``); empty (default) for none.
    optional
        Whether a cell may be empty (a missing value); default ``False``.
    choices
        The values a string column may take; default ``None``: any.
    low, high
        Inclusive bounds of a number, in ``unit``; default ``None``: unbounded.
    since
        The data-format version (:data:`DATA_FORMAT`) that added the column; files written
        before it lack it. Default ``'0.1'``, the first.
    """

    name: str
    kind: type
    doc: str
    unit: str = ""
    optional: bool = False
    choices: tuple[str, ...] | None = None
    low: float | None = None
    high: float | None = None
    since: str = "0.1"  # the data-format version that added the column


COMMON = (
    Column("study", str, "study name (the protocol's study.name)"),
    Column("participant", str, "participant id"),
    Column("session", int, "session number", low=1),
    Column("trial", int, "trial number within the session, from 1", low=1),
    Column("block", str, "block of the trial"),
    Column(
        "onset_s",
        float,
        "onset of the trial's stimulus: the flip that first showed it, on the clock of the run "
        "that recorded the trial (the PsychoPy log's time base; the sidecar's runs give each "
        "run's clock epoch and trials)",
        unit="s",
        low=0.0,
        since="0.2",
    ),
    Column(
        "time_s",
        float,
        "response time: from the onset flip of the trial's stimulus to the key press that "
        "ended the trial (matching: the Enter confirming the settings; staircase: the "
        "answer; rating: the rating key)",
        unit="s",
        low=0.0,
    ),
    Column(
        "dropped_frames",
        int,
        "frames dropped while the trial's stimulus was on a timed presentation (the "
        "staircase's flash); static screens are drawn once per change and drop none",
        low=0,
    ),
    Column(
        "ignored_keys",
        str,
        "key presses not taken as input during the trial or before its onset, as "
        "name@seconds from the onset (negative: before it), separated by ';'",
        optional=True,
        since="0.2",
    ),
)


def columns(protocol: Protocol) -> tuple[Column, ...]:
    """Every column of a protocol's session CSV, in file order: :data:`COMMON`, then those its
    paradigm derives from the protocol (methods, levels, questions, contexts, scale).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        A loaded protocol (:func:`glarelab.protocols.load_protocol`).

    Returns
    -------
    tuple of Column
        The columns, in the order the CSV has them.
    """
    from glarelab.protocols.core import PARADIGMS

    return COMMON + PARADIGMS[protocol.paradigm].columns(protocol)


def format_value(value: object, column: Column) -> str:
    """A value as written in the CSV (floats with full precision, booleans as true/false).

    Parameters
    ----------
    value
        The value of the cell; ``None`` or ``''`` is a missing value (an empty cell).
    column
        The column it is written in, whose ``kind`` decides the format.

    Returns
    -------
    str
        The cell's text: ``repr`` of a float (it reads back to the same number), ``true`` or
        ``false`` for a boolean, ``str`` otherwise, ``''`` for a missing value.

    Raises
    ------
    ValueError
        If the value is missing and the column is not ``optional``.
    """
    if value is None or value == "":
        if not column.optional:
            raise ValueError(f"column {column.name} needs a value")
        return ""
    if column.kind is bool:
        return "true" if value else "false"
    if column.kind is float:
        return repr(float(value))
    return str(value)


def row_digest(cells: Iterable[str]) -> str:
    """The digest of one CSV row as a session wrote it, kept in the sidecar's ``row_sha256``.

    An edit to a row (a value changed in a spreadsheet, a label swapped, a row copied from
    another session) changes its digest, so the analysis can name the row; the digest is taken
    over the cells' text in the schema's column order, so moving a column, re-ordering the rows
    or changing the line endings does not.

    Parameters
    ----------
    cells
        The row's cells as written (:func:`format_value`), in the order of :func:`columns`.

    Returns
    -------
    str
        The first :data:`ROW_DIGEST_HEX_DIGITS` hexadecimal digits of the sha256 of the cells
        as a JSON list (compact, UTF-8), so that no two rows share a text.

    Examples
    --------
    >>> row_digest(["p01", "1", "true"])
    '5e2465a763afae07'
    """
    if isinstance(cells, str | bytes) or not isinstance(cells, Iterable):
        raise TypeError(
            f"row_digest: cells must be the row's cells as a list of text; got {cells!r}"
        )
    cells = list(cells)
    others = [cell for cell in cells if not isinstance(cell, str)]
    if others:  # 3 and "3" are different JSON: a digest no CSV row, read as text, can have
        raise TypeError(
            f"row_digest: cells must be the row's cells as written, text (format_value); "
            f"got {others[0]!r}"
        )
    text = json.dumps(cells, ensure_ascii=False, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:ROW_DIGEST_HEX_DIGITS]
