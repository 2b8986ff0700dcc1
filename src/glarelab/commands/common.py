"""What every command shares: the parser's manners, checked argument types, output folders
that never lose a file, a memory check before large work, and the progress log."""

from __future__ import annotations

import argparse
import contextlib
import copy
import math
import os
import sys
from collections.abc import Iterator
from pathlib import Path

from glarelab.files.atomic import write_text
from glarelab.files.folders import (
    claim_files,
    edited_since,
    files_claimed,
    list_files,
    listed_files,
    without_link_loop,
)
from glarelab.files.inputs import loads_json
from glarelab.files.memory import available_memory, refuse_beyond
from glarelab.files.values import DECIMAL_TEXT, WHOLE_TEXT

__all__ = [
    "FORCE_HELP",
    "MARKER",
    "PROTOCOL_HELP",
    "HelpFormatter",
    "Parser",
    "add_accept_calibration",
    "check_memory",
    "claim_output",
    "count",
    "folder_to_write",
    "inside_whole_output",
    "log",
    "number",
    "output_file",
    "output_folder",
    "writes_into",
    "writing_into",
]

PROTOCOL_HELP = "a shipped study's name (yoshida2008, spencer1995, luidolt2020, …) or a TOML file"
WHOLE_OUTPUTS = {"stimulus set", "report", "demo"}  # folders replaced and checked whole
CALIBRATION_FORMAT = "glarelab display calibration v1"  # glarelab.display.calibration.FORMAT
MARKER = ".glarelab"  # names the command that made a folder, so it may replace its own output
FORCE_HELP = "overwrite an existing file glarelab did not write, or replace a symbolic link"


def log(message: str) -> None:
    """A progress line on stderr (stdout keeps what a command prints as its result).

    Parameters
    ----------
    message
        The line, after ``[glarelab]``.
    """
    print(f"[glarelab] {message}", file=sys.stderr, flush=True)


class HelpFormatter(argparse.HelpFormatter):
    """Help that shows every option's default (when it has one worth saying), also for an
    option without a help text (argparse prints nothing for those)."""

    @staticmethod
    def _default(action: argparse.Action) -> str | None:
        default = action.default
        if not action.option_strings or default in (None, False, "", argparse.SUPPRESS):
            return None
        shown = " ".join(map(str, default)) if isinstance(default, list | tuple) else default
        return str(shown).replace("%", "%%")  # the help text is a %-format

    def _format_action(self, action: argparse.Action) -> str:
        if action.help is None and self._default(action) is not None:
            action = copy.copy(action)
            action.help = f"default {self._default(action)}"
        return super()._format_action(action)

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        shown = self._default(action)
        if shown is None or "default" in text:
            return text
        return f"{text} (default {shown})" if text else f"default {shown}"


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line, naming the command and the problem.

    Parameters
    ----------
    args, kwargs
        As for :class:`argparse.ArgumentParser`; the help formatter defaults to
        :class:`HelpFormatter`.
    """

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        """Print ``message`` on one line after the command's name, and exit with status 2.

        Parameters
        ----------
        message
            What is wrong, as argparse words it.
        """
        required = "the following arguments are required: "
        if message.startswith(required) and any(
            not name.startswith("-") for name in message.removeprefix(required).split(", ")
        ):  # a positional argument missing: the ones given may have been read as another
            message += self._positionals_read()
            if "--protocol" in getattr(self, "_arguments", ()) and "STUDY as" in message:
                message += (
                    "; with --protocol FILE give two or more CSVs, or one CSV after the study "
                    "(STUDY CSV --protocol FILE)"
                )
        print(f"{self.prog}: {message} (see {self.prog} --help)", file=sys.stderr)
        raise SystemExit(2)

    def _positionals_read(self) -> str:
        """What the positional arguments given were read as (``import-psychopy /dev/null``
        reads the file as the study), for a refusal of missing ones; empty if none given."""
        given, tokens = [], iter(getattr(self, "_arguments", ()))
        for token in tokens:
            if token == "--":
                given += list(tokens)
            elif token.startswith("-") and len(token) > 1:
                action = self._option_string_actions.get(token.split("=", 1)[0])
                if action is not None and action.nargs != 0 and "=" not in token:
                    next(tokens, None)  # the option's value
            else:
                given.append(token)
        positionals = [a for a in self._actions if not a.option_strings]
        read = [
            f"{(action.metavar or action.dest).upper()} as {token!r}"
            for action, token in zip(positionals, given, strict=False)
        ]
        return f"; read {', '.join(read)}" if read else ""

    # options that may be given more than once (each adds to a list, or counts)
    _REPEATABLE = (
        argparse._AppendAction,
        argparse._AppendConstAction,
        argparse._CountAction,
        argparse._ExtendAction,
        argparse._HelpAction,
        argparse._VersionAction,
        argparse._SubParsersAction,
    )

    def parse_known_args(self, args=None, namespace=None):
        """Parse as :meth:`argparse.ArgumentParser.parse_known_args`, refusing an option given
        twice (unless it adds to a list or counts) and an empty path.

        Parameters
        ----------
        args
            The command-line arguments (list of str); default None: ``sys.argv[1:]``.
        namespace
            The object to set the options on; default None: a new
            :class:`argparse.Namespace`.

        Returns
        -------
        tuple
            The namespace and the list of arguments not parsed.
        """
        self._given: set[int] = set()  # the options met in this parse
        self._arguments = [str(a) for a in (sys.argv[1:] if args is None else args)]
        namespace, extras = super().parse_known_args(args, namespace)
        # which options were given, whatever their value: an option given at its default
        # value to a mode that ignores it is refused too (--regime photopic with --model
        # gaussian); a subcommand's parser has set its own already
        mine = {a.dest for a in self._actions if id(a) in self._given}
        namespace.given_options = set(getattr(namespace, "given_options", set())) | mine
        return namespace, extras

    def _get_values(self, action, arg_strings):
        # called once for each option on the command line: a second one would silently win
        if action.option_strings and not isinstance(action, self._REPEATABLE):
            given = getattr(self, "_given", None)
            if given is not None and id(action) in given:
                self.error(
                    f"{'/'.join(action.option_strings)} is given twice; give it once (the "
                    "second would silently replace the first)"
                )
            if given is not None:
                given.add(id(action))
        name = "/".join(action.option_strings) or action.metavar or action.dest
        if action.type is Path and any(not text.strip() for text in arg_strings):
            self.error(
                f"{name} is empty (an unset shell variable?): give a path; an empty one would "
                "mean the working folder"
            )
        values = super()._get_values(action, arg_strings)
        if action.dest == "out" and isinstance(values, str | Path):
            whole = inside_whole_output(Path(values))
            if whole is not None:
                self.error(
                    f"{name} {values} is inside the {whole}, which glarelab writes and checks "
                    "as a whole: write elsewhere (nothing was changed)"
                )
        return values


def number(low: float | None = None, high: float | None = None, *, above: bool = False):
    """An argparse type: a finite number in ``[low, high]`` (``(low, high]`` if ``above``).

    Parameters
    ----------
    low
        The smallest value allowed; default None: no bound.
    high
        The largest value allowed; default None: no bound.
    above
        Whether ``low`` itself is refused; default False.

    Returns
    -------
    callable
        ``parse(text) -> float``, raising :class:`argparse.ArgumentTypeError` for text out
        of range or not a number.
    """

    def parse(text: str) -> float:
        # as a number is written: not Python's 0.0_2 (0.02) or a number padded with spaces
        if DECIMAL_TEXT.fullmatch(text) is None:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number")
        value = float(text)
        bad = not math.isfinite(value)
        bad |= low is not None and (value <= low if above else value < low)
        bad |= high is not None and value > high
        if bad:
            left = "(" if above else "["
            if high is not None:
                allowed = f" in {left}{low if low is not None else '-inf'}, {high}]"
            elif low is not None:
                allowed = f" {'>' if above else '>='} {low}"
            else:
                allowed = ""
            raise argparse.ArgumentTypeError(f"{text} must be a finite number{allowed}")
        return value

    return parse


def count(low: int = 1, high: int | None = None):
    """An argparse type: a whole number in ``[low, high]``.

    Parameters
    ----------
    low
        The smallest value allowed; default 1.
    high
        The largest; default None: no bound.

    Returns
    -------
    callable
        ``parse(text) -> int``, raising :class:`argparse.ArgumentTypeError` for text out
        of range or not a whole number.
    """

    def parse(text: str) -> int:
        if WHOLE_TEXT.fullmatch(text) is None:  # not Python's 1_000, nor ' 12'
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number")
        value = int(text)
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(
                f"{value} must be a whole number from {low}{f' to {high}' if high else ' up'}"
            )
        return value

    return parse


def one_line(text: str) -> str:
    """An argparse type: text of one line, no control characters (a label that goes into
    files and one-line messages).

    Parameters
    ----------
    text
        The option's value.

    Returns
    -------
    str
        ``text``, unchanged.

    Raises
    ------
    argparse.ArgumentTypeError
        For a line break, a tab or another control character, naming it.
    """
    control = next((ch for ch in text if not ch.isprintable()), None)
    if control is not None:
        raise argparse.ArgumentTypeError(
            f"{text!r} holds {control!r}: must be one line of text, without line breaks, "
            "tabs or other control characters"
        )
    return text


def output_folder(path: Path, command: str) -> Path:
    """The folder a command fills with files of its choosing: created if new, and reused only
    when the same command made it (a previous output, which it may replace). A file, or a
    folder holding anything else, is refused before anything is written.

    Parameters
    ----------
    path
        The folder (``--out``).
    command
        The command's name, recorded in the folder's ``.glarelab`` marker.

    Returns
    -------
    pathlib.Path
        ``path``, existing.

    Raises
    ------
    ValueError
        Naming the folder and why.
    """
    path = without_link_loop(path, what=f"{command} output")
    if path.exists() and not path.is_dir():
        raise ValueError(f"--out {path} is a file; give a folder for the {command} output")
    if path.is_dir() and any(path.iterdir()):
        marker = path / MARKER
        made_by = marker.read_text().strip() if marker.is_file() else None
        if made_by != command:
            raise ValueError(
                f"--out {path} is a folder with files glarelab {command} did not write "
                f"({'made by glarelab ' + made_by if made_by else 'not a glarelab output'}); "
                "give a new or empty folder — nothing was changed"
            )
    path.mkdir(parents=True, exist_ok=True)
    marker = path / MARKER
    if not marker.is_file() or marker.read_text() != command + "\n":  # unchanged if so
        write_text(marker, command + "\n")
    return path


def writes_into(path: Path, names: list[str], command: str, *, force: bool = False) -> Path:
    """A folder a command writes a fixed set of named files into (``docs``, ``gallery``, …):
    created if new; a file of that name glarelab did not write there is refused
    (``glarelab.files.folders.claim_files``); other files in it are left alone.

    Parameters
    ----------
    path
        The folder.
    names
        The files the command writes, relative to ``path``.
    command
        The command's name, the kind the files are listed as.
    force
        Whether to overwrite a file of ``names`` edited since glarelab wrote it (``--force``);
        default False.

    Returns
    -------
    pathlib.Path
        ``path``, existing.

    Raises
    ------
    ValueError
        If ``path`` is a file, or a file of ``names`` is there and glarelab did not write it.
    """
    path, _ = _folder_made(path, names)
    claim_files(path, names, command, force=force)
    return path


@contextlib.contextmanager
def writing_into(
    path: Path, names: list[str], command: str, *, force: bool = False
) -> Iterator[Path]:
    """:func:`writes_into` for the work done inside the ``with`` block: should it be refused
    or fail before a file is written, the folder is left as it was found (the claims of the
    files not written dropped, the folder removed if it was made for them and is empty).

    Parameters
    ----------
    path, names, command, force
        As for :func:`writes_into`.

    Yields
    ------
    pathlib.Path
        ``path``, existing.
    """
    path, created = _folder_made(path, names)
    with files_claimed(path, names, command, force=force, created=created):
        yield path


def _folder_made(path: Path, names: list[str]) -> tuple[Path, bool]:
    """The folder :func:`writes_into` and :func:`writing_into` write ``names`` into, checked
    (:func:`folder_to_write`) and made; and whether it was made now."""
    path = folder_to_write(path, names)
    created = not (path.exists() or path.is_symlink())
    path.mkdir(parents=True, exist_ok=True)
    return path, created


def folder_to_write(path: Path, names: list[str]) -> Path:
    """:func:`writes_into`'s checks of ``path`` alone, before anything is made.

    Parameters
    ----------
    path
        The folder.
    names
        The files to be written in it (named in the error).

    Returns
    -------
    pathlib.Path
        ``path``, a symbolic link loop resolved away.

    Raises
    ------
    ValueError
        If ``path`` is a file, or a stimulus set or report (or inside one).
    """
    path = without_link_loop(path, what=", ".join(names))
    if path.exists() and not path.is_dir():
        raise ValueError(f"{path} is a file; give a folder for {', '.join(names)}")
    whole = inside_whole_output(path / names[0]) if names else None
    if whole is not None:  # the folder is a stimulus set or report, or inside one
        raise ValueError(
            f"{path} is or is inside the {whole}, which glarelab writes and checks as a "
            "whole: write elsewhere (nothing was changed)"
        )
    return path


def _same_file(first: Path, second: Path) -> bool:
    try:
        return first.resolve() == second.resolve() or (
            first.exists() and second.exists() and os.path.samefile(first, second)
        )
    except OSError:
        return False


def inside_whole_output(path: Path) -> str | None:
    """What kind of whole output (a stimulus set, a report) holds ``path``, if one does.

    Parameters
    ----------
    path
        A file or folder.

    Returns
    -------
    str or None
        ``'KIND FOLDER'`` of the innermost such output, or None.
    """
    for folder in Path(path).absolute().parents:
        kinds = set(listed_files(folder).values())
        whole = sorted(kinds & WHOLE_OUTPUTS)
        if whole:
            return f"{whole[0]} {folder}"
        manifest = folder / "manifest.json"
        if manifest.is_file() and manifest.stat().st_size < 2**26:
            try:
                data = loads_json(manifest.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                continue
            if isinstance(data, dict) and str(data.get("format", "")).startswith(
                "glarelab stimulus set"
            ):
                return f"stimulus set {folder}"
    return None


def verified_calibration(path: Path) -> str | None:
    """The status of the glarelab calibration at ``path`` if it holds one with a
    verification pass (``passed`` or ``failed``), else None."""
    path = Path(path)
    if not path.is_file() or path.stat().st_size > 2**26:
        return None
    try:
        data = loads_json(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if isinstance(data, dict) and data.get("format") == CALIBRATION_FORMAT:
        status = data.get("status")
        if status in ("passed", "failed") or data.get("verification"):
            return str(status)
    return None


def output_file(
    path: Path,
    suffixes: tuple[str, ...],
    what: str,
    *,
    inputs=(),
    force: bool = False,
    shared: bool = False,
    verified_ok: bool = False,
    forceable: bool = True,
) -> Path:
    """A file a command writes: its suffix must say what it holds, it must not be an input,
    a file of a stimulus set or report, or a verified calibration; its folder must exist and
    be writable.
    Without ``force`` it must not be a symbolic link, nor a file glarelab did not write there
    (as the folder's listing, :mod:`glarelab.files.folders`, says); ``shared`` says the caller
    has checked the folder's listing itself (a batch of outputs).

    Parameters
    ----------
    path
        The file to write.
    suffixes
        The suffixes allowed, lower case with the dot (``('.png',)``).
    what
        What the file holds, for the messages.
    inputs
        The command's input files, none of which may be ``path``; default none.
    force
        Whether to overwrite a file glarelab did not write, or replace a link; default False.
    shared
        Whether the caller has checked the folder's listing itself; default False.
    verified_ok
        Whether a verified calibration may be overwritten (``calibrate fit --replace``,
        which keeps the earlier one beside it); default False.
    forceable
        Whether the command has ``--force`` (the messages offer it); default True.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        Naming the file and why (nothing is written).
    """
    path = without_link_loop(path, what=what)
    if path.suffix.lower() not in suffixes:
        raise ValueError(
            f"{path}: {what} must be named {' or '.join(suffixes)} (got {path.suffix or 'none'})"
        )
    if path.is_dir():
        raise ValueError(f"{path} is a folder; give a file name for the {what}")
    for source in inputs:
        if source is not None and _same_file(Path(source), path):
            raise ValueError(f"{path} is also an input: the {what} would overwrite it")
    if not path.parent.is_dir():
        raise ValueError(f"{path}: no folder {path.parent} to write the {what} into")
    if not os.access(path.parent, os.W_OK | os.X_OK):  # before the work, not after it
        raise ValueError(
            f"{path}: the folder {path.parent} cannot be written into (read-only, or not this "
            f"user's to write); give the {what} a folder you may write into (nothing was done)"
        )
    whole = inside_whole_output(path)
    if whole is not None:
        raise ValueError(
            f"{path} is inside the {whole}, which glarelab writes and checks as a whole: write "
            f"the {what} elsewhere (nothing was changed)"
        )
    status = None if verified_ok else verified_calibration(path)
    if status is not None:
        raise ValueError(
            f"{path} is a display calibration with a verification pass ({status}): the {what} "
            "would overwrite it; give another name (nothing was changed)"
        )
    overwrite = f", or --force to overwrite it with the {what}" if forceable else ""
    if path.is_symlink() and not force:
        replace = f", or --force to replace the link with the {what}" if forceable else ""
        raise ValueError(
            f"{path} is a symbolic link (to {os.readlink(path)}); glarelab does not write "
            f"through links: give another name{replace}"
        )
    if path.exists() and not force and not shared and path.name not in listed_files(path.parent):
        raise ValueError(
            f"{path} exists and glarelab did not write it there; give another name{overwrite} "
            "(nothing was changed)"
        )
    if not force and edited_since(path.parent, path.name):  # a gallery figure retouched
        raise ValueError(
            f"{path} was edited since glarelab wrote it; give another name{overwrite} (nothing "
            "was changed)"
        )
    return path


def claim_output(path: Path, kind: str) -> Path:
    """Just before writing ``path``: list it as glarelab's (so a later run may replace it).

    Parameters
    ----------
    path
        The file about to be written.
    kind
        The kind of output it is listed as.

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    path = Path(path)
    list_files(path.parent, [path.name], kind)
    return path


def check_memory(needed: float, what: str) -> None:
    """Refuse work that needs more memory than the system has, before allocating it.

    Parameters
    ----------
    needed
        Bytes the work needs.
    what
        The work, for the message.

    Raises
    ------
    ValueError
        If Linux reports less memory available than ``needed`` (elsewhere nothing is
        checked).
    """
    refuse_beyond(needed, available_memory(), what)  # available_memory: patched in tests


MONITOR_HELP = (
    "a PsychoPy Monitor Center monitor: its size in pixels, width and distance replace the "
    "protocol display's geometry, and the window is opened with it"
)


def add_monitor_options(parser: argparse.ArgumentParser, *, gamma: bool = False) -> None:
    """``--monitor NAME`` and ``--monitor-folder DIR`` (Monitor Center's by default)."""
    parser.add_argument(
        "--monitor",
        default=None,
        metavar="NAME",
        help=MONITOR_HELP
        + (
            "; without --calibration, its luminance calibration (its measurements, or its "
            "gamma grid) encodes the images"
            if gamma
            else ""
        ),
    )
    parser.add_argument(
        "--monitor-folder",
        type=Path,
        default=None,
        metavar="DIR",
        help="Monitor Center's folder of monitors (default PsychoPy's, ~/.psychopy3/monitors)",
    )


def apply_monitor(args: argparse.Namespace, protocol):
    """The protocol with ``--monitor``'s geometry, and the monitor (None without one)."""
    if getattr(args, "monitor", None) is None:
        if getattr(args, "monitor_folder", None) is not None:
            raise ValueError("--monitor-folder needs --monitor NAME (the monitor to use)")
        return protocol, None
    from glarelab.frontend.monitors import load_monitor, monitor_display
    from glarelab.protocols import with_monitor

    monitor = load_monitor(args.monitor, folder=args.monitor_folder)
    facts = monitor_display(monitor)
    protocol = with_monitor(
        protocol,
        name=args.monitor,
        resolution_px=facts["resolution_px"],
        width_cm=facts["width_cm"],
        distance_cm=facts["distance_cm"],
    )
    log(
        f"monitor {args.monitor!r} of Monitor Center (calibration {facts['calibration']}): "
        f"{facts['resolution_px']} px, {facts['width_cm']} cm wide, seen from "
        f"{facts['distance_cm']} cm"
    )
    return protocol, monitor


def add_accept_calibration(parser: argparse.ArgumentParser, help_text: str) -> None:
    """Add ``--accept-mismatch calibration`` (``stimuli build``, ``check-display``): go on
    although the calibration's white is not the protocol display's, recorded.

    Parameters
    ----------
    parser
        The command's parser.
    help_text
        The option's help: what the command does anyway.
    """
    parser.add_argument(
        "--accept-mismatch",
        nargs="+",
        choices=("calibration",),
        metavar="CHECK",
        help=help_text,
    )
