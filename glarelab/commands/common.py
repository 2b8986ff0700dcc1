"""What every command shares: the parser's manners, checked argument types, output folders
that never lose a file, a memory check before large work, and the progress log."""

from __future__ import annotations

import argparse
import copy
import math
import os
import sys
from pathlib import Path

from protocols.atomic import write_text
from protocols.folders import claim_files

__all__ = [
    "MARKER",
    "PROTOCOL_HELP",
    "HelpFormatter",
    "Parser",
    "check_memory",
    "count",
    "log",
    "number",
    "output_file",
    "output_folder",
    "writes_into",
]

PROTOCOL_HELP = "a shipped study's name (yoshida2008, spencer1995, luidolt2020, …) or a TOML file"
MARKER = ".glarelab"  # names the command that made a folder, so it may replace its own output


def log(message: str) -> None:
    """A progress line on stderr (stdout keeps what a command prints as its result)."""
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
    """An argument parser whose errors are one line, naming the command and the problem."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str):
        print(f"{self.prog}: {message} (see {self.prog} --help)", file=sys.stderr)
        raise SystemExit(2)


def number(low: float | None = None, high: float | None = None, *, above: bool = False):
    """An argparse type: a finite number in ``[low, high]`` (``(low, high]`` if ``above``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        bad = not math.isfinite(value)
        bad |= low is not None and (value <= low if above else value < low)
        bad |= high is not None and value > high
        if bad:
            left = "(" if above else "["
            raise argparse.ArgumentTypeError(
                f"{text} must be a finite number in {left}{low if low is not None else '-inf'}, "
                f"{high if high is not None else 'inf'}]"
            )
        return value

    return parse


def count(low: int = 1, high: int | None = None):
    """An argparse type: a whole number in ``[low, high]``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(
                f"{value} must be a whole number from {low}{f' to {high}' if high else ' up'}"
            )
        return value

    return parse


def output_folder(path: Path, command: str) -> Path:
    """The folder a command fills with files of its choosing: created if new, and reused only
    when the same command made it (a previous output, which it may replace). A file, or a
    folder holding anything else, is refused before anything is written.

    Raises
    ------
    ValueError
        Naming the folder and why.
    """
    path = Path(path)
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
    write_text(path / MARKER, command + "\n")
    return path


def writes_into(path: Path, names: list[str], command: str) -> Path:
    """A folder a command writes a fixed set of named files into (``docs``, ``gallery``, …):
    created if new; a file of that name glarelab did not write there is refused
    (``protocols.folders.claim_files``); other files in it are left alone."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{path} is a file; give a folder for {', '.join(names)}")
    path.mkdir(parents=True, exist_ok=True)
    claim_files(path, names, command)
    return path


def output_file(path: Path, suffixes: tuple[str, ...], what: str, *, inputs=()) -> Path:
    """A file a command writes: its suffix must say what it holds, it must not be an input, and
    its folder must exist."""
    path = Path(path)
    if path.suffix.lower() not in suffixes:
        raise ValueError(
            f"{path}: {what} must be named {' or '.join(suffixes)} (got {path.suffix or 'none'})"
        )
    if path.is_dir():
        raise ValueError(f"{path} is a folder; give a file name for the {what}")
    for source in inputs:
        same = Path(source).resolve() == path.resolve() or (
            path.exists() and Path(source).exists() and os.path.samefile(source, path)
        )
        if same:
            raise ValueError(f"{path} is also an input: the {what} would overwrite it")
    if not path.parent.is_dir():
        raise ValueError(f"{path}: no folder {path.parent} to write the {what} into")
    return path


def available_memory() -> int | None:
    """Bytes the system can still give (Linux's MemAvailable); None where unknown."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def check_memory(needed: float, what: str) -> None:
    """Refuse work that needs more memory than the system has, before allocating it."""
    free = available_memory()
    if free is not None and needed > free:
        raise ValueError(
            f"{what} needs about {needed / 2**30:.1f} GiB of memory, {free / 2**30:.1f} GiB "
            "are available; use a smaller size"
        )
