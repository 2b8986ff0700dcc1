"""Files glarelab reads: a regular file, or an error saying what is there instead.

A folder, a named pipe (FIFO), a device such as ``/dev/null`` or a symbolic-link loop given
where a file is read gets a message naming it, not "no such file"; a FIFO is never opened
(opening one waits for a writer, for ever). Text is read as UTF-8 (with or without a
byte-order mark) or, when it starts with their byte-order mark, as UTF-16 or UTF-32, as
spreadsheets and Windows editors save it ("Unicode text"); any other encoding is refused with
the place of its first byte that is not UTF-8 (a NUL byte: UTF-16 without its mark).
JSON is parsed by :func:`loads_json`: arrays or objects nested deeper than Python's parser
recurses are refused as JSON that cannot be read, not a crash.
"""

from __future__ import annotations

import codecs
import errno
import json
import os
import stat
from pathlib import Path

__all__ = [
    "NESTED_TOO_DEEPLY",
    "JSONNestingError",
    "as_path",
    "input_file",
    "loads_json",
    "read_input_text",
]

NESTED_TOO_DEEPLY = "arrays or objects nested too deeply (glarelab's JSON files nest a few levels)"

_BOMS = (  # longest first: UTF-32-LE's mark starts with UTF-16-LE's
    (codecs.BOM_UTF32_LE, "utf-32"),
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)


def as_path(path: object, *, what: str) -> Path:
    """``path`` as a :class:`~pathlib.Path`, or a TypeError naming ``what`` and the value.

    Parameters
    ----------
    path
        A ``str`` or :class:`os.PathLike` (bytes are refused: glarelab's paths are text).
    what
        What the path is for (``'protocol'``, ``'readings file'``).

    Returns
    -------
    pathlib.Path
        ``Path(path)``.

    Raises
    ------
    TypeError
        For anything else, naming ``what`` and the value.
    ValueError
        For an empty text (``Path('')`` would be the working folder).

    Examples
    --------
    >>> as_path(None, what="readings file")
    Traceback (most recent call last):
    ...
    TypeError: readings file: a path (str or os.PathLike) is needed; got None
    """
    if isinstance(path, Path):
        return path
    if isinstance(path, str) and not path.strip():  # Path('') is the working folder
        raise ValueError(f"{what}: the path is empty (an unset shell variable?); give a file")
    if isinstance(path, str) or (
        isinstance(path, os.PathLike) and isinstance(os.fspath(path), str)
    ):
        return Path(path)
    raise TypeError(f"{what}: a path (str or os.PathLike) is needed; got {path!r:.80}")


def _kind(mode: int) -> str:
    """What a file that is not a regular file is, in words."""
    if stat.S_ISDIR(mode):
        return "a folder, not a file"
    if stat.S_ISFIFO(mode):
        return "a named pipe (FIFO), not a regular file"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device (as /dev/null is), not a regular file"
    if stat.S_ISSOCK(mode):
        return "a socket, not a regular file"
    return "not a regular file"


def input_file(path: str | os.PathLike, *, what: str) -> Path:
    """``path`` as a :class:`~pathlib.Path` when it is a regular file (or a link to one).

    Parameters
    ----------
    path
        The file to read.
    what
        What the file is for, the start of every message (``'readings file'``,
        ``'protocol file'``).

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    FileNotFoundError
        If there is nothing at ``path`` (a dangling link included).
    IsADirectoryError
        If ``path`` is a folder.
    ValueError
        If ``path`` is a named pipe, a device, a socket, or a symbolic-link loop.

    Examples
    --------
    >>> input_file("/dev/null", what="readings file")
    Traceback (most recent call last):
    ...
    ValueError: readings file /dev/null: a device (as /dev/null is), not a regular file
    """
    path = as_path(path, what=what)
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise FileNotFoundError(f"no {what} at {path}") from None
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise ValueError(f"{what} {path}: a loop of symbolic links, not a file") from None
        raise
    if stat.S_ISREG(mode):
        return path
    if stat.S_ISDIR(mode):
        raise IsADirectoryError(f"{what} {path}: {_kind(mode)}")
    raise ValueError(f"{what} {path}: {_kind(mode)}")


def read_input_text(path: str | os.PathLike, *, what: str) -> str:
    """The text of the regular file ``path``: UTF-8, or UTF-16/32 with a byte-order mark.

    Parameters
    ----------
    path
        The file to read.
    what
        What the file is for, the start of every message (as :func:`input_file`).

    Returns
    -------
    str
        The text, without its byte-order mark; line ends as in the file.

    Raises
    ------
    FileNotFoundError, IsADirectoryError
        As :func:`input_file`.
    ValueError
        As :func:`input_file`, or for text in another encoding (naming the byte).

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = Path(folder) / "readings.csv"
    ...     _ = path.write_text("code,luminance_cd_m2\\n", encoding="utf-16")
    ...     read_input_text(path, what="readings file")
    'code,luminance_cd_m2\\n'
    """
    data = input_file(path, what=what).read_bytes()
    encoding = next((name for mark, name in _BOMS if data.startswith(mark)), "utf-8")
    nul = data.find(b"\x00") if encoding == "utf-8" else -1
    if nul >= 0:  # text has no NUL; UTF-16 has one in each ASCII letter
        raise ValueError(
            f"{what} {path}: byte {nul} is a NUL: UTF-16 text without its "
            "byte-order mark, or not text; save it as UTF-8 (a spreadsheet's 'CSV UTF-8')"
        )
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as error:
        raise ValueError(
            f"{what} {path}: byte {error.start} is not {encoding.upper().removesuffix('-SIG')} "
            "text; save it as UTF-8 (a spreadsheet's 'CSV UTF-8')"
        ) from None


class JSONNestingError(json.JSONDecodeError):
    """JSON nested too deeply to parse: a :class:`json.JSONDecodeError` (so a
    :class:`ValueError`), handled wherever invalid JSON is, whose message is one line.

    Parameters
    ----------
    doc
        The JSON text (or its bytes).
    source
        The file it was read from, to start the message; None: the message alone.
    """

    def __init__(self, doc: str | bytes, source: object = None) -> None:
        text = doc if isinstance(doc, str) else doc.decode("utf-8", "replace")
        super().__init__(NESTED_TOO_DEEPLY, text, 0)
        self.args = (f"{source}: {NESTED_TOO_DEEPLY}" if source else NESTED_TOO_DEEPLY,)


def loads_json(data: str | bytes, *, source: object = None) -> object:
    """``json.loads(data)``, the one way glarelab parses JSON read from a file: nesting
    too deep for the parser (``'[' * 100000``) is refused as invalid JSON, where
    ``json.loads`` raises RecursionError.

    Parameters
    ----------
    data
        The JSON text (or its UTF-8 bytes).
    source
        The file it was read from, to start the message of a refusal that no caller wraps;
        default None: the message alone (for a caller that names the file itself).

    Returns
    -------
    object
        The value.

    Raises
    ------
    json.JSONDecodeError
        For invalid JSON; :class:`JSONNestingError` for JSON nested too deeply.

    Examples
    --------
    >>> loads_json('{"a": [1, 2]}')
    {'a': [1, 2]}
    >>> try:
    ...     loads_json("[" * 100000 + "]" * 100000, source="deep.json")
    ... except ValueError as error:
    ...     print(error)
    deep.json: arrays or objects nested too deeply (glarelab's JSON files nest a few levels)
    """
    try:
        return json.loads(data)
    except RecursionError:
        raise JSONNestingError(data, source) from None
