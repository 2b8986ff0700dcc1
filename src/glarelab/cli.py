"""The ``glarelab`` command: its parser, made of the command modules of
:mod:`glarelab.commands`, and the one place errors become messages and exit statuses.

Exit statuses: 0 done; 1 a check that found problems (``stimuli verify``, ``check-display``,
``calibrate measure`` whose calibration failed); 2 refused: a bad argument, file or value, named
in one line on stderr, nothing written; 3 a session stopped before it completed (Escape,
Ctrl-C, kill), or any command stopped by Ctrl-C, SIGTERM or SIGHUP (every file it wrote whole,
its unfinished output removed); 4 a session stopped because its files could not be written (a
full disk): its trials so far are on disk and its sidecar says why. An unexpected error prints
its traceback and asks for a bug report.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import signal
import sys
import traceback
import warnings
from collections.abc import Sequence
from importlib import metadata

from .commands import COMMANDS, MODULE_NAMES, load
from .commands.common import HelpFormatter, Parser
from .commands.common import log as _log

__all__ = ["main"]  # and build_model, the render command's, imported on use
NO_CACHE_ENV = (
    "GLARELAB_NO_CACHE"  # glarelab.glare.models.cache.NO_CACHE_ENV, without importing glare
)


def __getattr__(name: str):
    if name == "build_model":  # the render command's, imported with it
        return load("render").build_model
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


ISSUES = "a bug in glarelab: please report it with the command you ran and the lines above"


def _version() -> str:
    try:
        return metadata.version("glarelab")
    except metadata.PackageNotFoundError:  # pragma: no cover - run from a source tree
        return "unknown"


def _chosen(argv: Sequence[str]) -> str | None:
    """The command named in ``argv``: its first argument that is not an option."""
    return next((a for a in argv if not a.startswith("-")), None)


def _parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser. Only the module of the command in ``argv`` is imported (all of them when
    ``argv`` is None); the other commands are listed with their help from the table."""
    parser = Parser(
        prog="glarelab",
        description="Glare illusion psychophysics suite",
        formatter_class=HelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"glarelab {_version()}")
    parser.add_argument(
        "--no-cache",
        action="store_true",
        help="digitise every kernel instead of reading the kernel cache (glarelab cache info)",
    )
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    chosen = None if argv is None else _chosen(argv)
    for name in MODULE_NAMES:
        if argv is None or (chosen in COMMANDS and COMMANDS[chosen][0] == name):
            load(name).add(commands)
        else:
            for command, (module, text) in COMMANDS.items():
                if module == name:
                    commands.add_parser(command, help=text, add_help=False)
    return parser


def _refusal(error: BaseException) -> str | None:
    """The one-line message of an anticipated error, or None for a bug."""
    from glarelab.analysis.load import DataError
    from glarelab.display.photometer import PhotometerError, PluginMissing
    from glarelab.protocols import ProtocolError

    if isinstance(error, ProtocolError | DataError | PhotometerError | PluginMissing):
        return str(error)
    if isinstance(error, ValueError | FileNotFoundError | IsADirectoryError):
        return str(error)
    from glarelab.frontend.eyetracker import TrackerError

    if isinstance(error, TrackerError):
        return str(error)
    if isinstance(error, NotADirectoryError | PermissionError | FileExistsError):
        where = f" ({error.filename})" if error.filename else ""
        return f"{error.strerror or error}{where}"
    if isinstance(error, OSError) and error.errno in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT):
        where = f" writing {error.filename}" if error.filename else ""
        return f"the disk is full{where} ({error.strerror}); what was written before stays"
    if isinstance(error, OSError) and error.filename:  # a file that cannot be read or written
        return f"{error.filename}: {error.strerror or error}"
    if type(error).__name__ == "NoSuchDisplayException":  # pyglet, opening a window
        return (
            f"no display to open a window on (DISPLAY={os.environ.get('DISPLAY', '')!r}): run "
            "it on the lab's screen, or under xvfb-run for a dry run"
        )
    if isinstance(error, RuntimeError) and str(error).startswith("Symlink loop from "):
        # pathlib's resolve() up to Python 3.12; 3.13 raises OSError(ELOOP), named above
        where = str(error).removeprefix("Symlink loop from ")
        return f"{where}: a loop of symbolic links on the way; give a path without one"
    if isinstance(error, MemoryError):
        return "not enough memory for this size; try a smaller image or kernel"
    return None


def _one_line_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as one line on stderr, as the commands' other messages: what it says and
    its kind, without Python's source line (``warnings.showwarning``'s signature).

    >>> import io, contextlib
    >>> with contextlib.redirect_stderr(io.StringIO()) as err:
    ...     _one_line_warning(UserWarning("two\\nlines"), UserWarning, "x.py", 3)
    >>> err.getvalue()
    '[glarelab] warning (UserWarning): two lines\\n'
    """
    text = " ".join(str(message).split())
    print(f"[glarelab] warning ({category.__name__}): {text}", file=file or sys.stderr, flush=True)


def _quiet_stdout() -> None:
    """The reader of stdout went away (``glarelab … | head``): send the rest nowhere, so
    that Python's own flush at exit does not fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


def _stopped_while_starting(number: int, frame: object) -> None:
    """SIGINT while the program starts (imports, the parser): nothing was done, so it ends at
    once, rather than raising KeyboardInterrupt into a library's import that might swallow it
    (a signal handler)."""
    os.write(2, b"[glarelab] stopped by SIGINT while starting; nothing was done\n")
    os._exit(3)


def _stopped_while_ending(number: int, frame: object) -> None:
    """SIGINT after the command returned, while Python shuts down (threads, atexit): its work
    is done and its output flushed; end at once (a signal handler)."""
    os.write(2, b"[glarelab] stopped by SIGINT while exiting; the command had finished\n")
    os._exit(3)


def _forget_interrupt() -> None:
    """Make CPython forget a KeyboardInterrupt that passed through an ``eval`` or ``exec`` of a
    string (``collections.namedtuple``, ``dataclasses``, at import): it remembers one, and at
    exit kills itself by SIGINT (status -2 to the shell) instead of returning the status the
    command chose. Each ``exec`` of a string starts by resetting that memory."""
    exec("")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``glarelab`` command; returns the exit status.

    Ctrl-C (SIGINT), and as the program SIGTERM (a kill) and SIGHUP (a closed terminal), ends
    any command with status 3 and one line, whenever it comes, also
    where a library caught the KeyboardInterrupt and went on, or failed for what it cut; a
    closed pipe on stdout (SIGPIPE, ``| head``) ends it quietly with status 0. Run as the
    program (``argv`` None), a Ctrl-C before the command starts, or after it returned, ends
    the process at once: nothing is being written then (once Python tears its modules down,
    the last moment of all, it is ignored and the status is the command's).

    Parameters
    ----------
    argv
        The arguments after ``glarelab``; default None: :data:`sys.argv` without the
        program's name.

    Returns
    -------
    int
        The exit status, as the module docstring lists them (0 done, 1 a check found
        problems, 2 refused, 3 stopped, 4 files could not be written).
    """
    command = "glarelab"
    # the glarelab program, not a call from Python (a test, a script), and not started with
    # SIGINT ignored (a background job of a shell script, nohup), which it keeps
    program = argv is None and signal.getsignal(signal.SIGINT) is not signal.SIG_IGN
    # SIGTERM and SIGHUP are handled by the program whatever SIGINT's disposition: a script's
    # background job ignores SIGINT, and is stopped by its `kill`
    as_program = argv is None
    if program:
        signal.signal(signal.SIGINT, _stopped_while_starting)
    argv = sys.argv[1:] if argv is None else list(argv)
    previous = os.environ.get(NO_CACHE_ENV)
    args = None
    received: list[int] = []  # SIGINTs (SIGTERMs, SIGHUPs) the command was sent while it ran
    caught: list[int] = []  # the signals besides SIGINT handled as it, restored at the end

    def interrupted(number: int, frame) -> None:
        received.append(number)  # kept even where a library swallows the KeyboardInterrupt
        signal.default_int_handler(number, frame)

    try:
        parser = _parser(argv)
        args = parser.parse_args(argv)
        command = args.command
        from glarelab.experiments.loop import SessionAborted

        if args.no_cache:  # for this command and the processes it starts (Dask workers)
            os.environ[NO_CACHE_ENV] = "1"
        try:
            if os.environ.get(NO_CACHE_ENV, "") not in ("", "0", "1"):  # cache.NO_CACHE_VALUES
                raise ValueError(
                    f"{NO_CACHE_ENV} must be 1 (no kernel cache, as --no-cache), 0 or unset (the "
                    f"cache), got {os.environ[NO_CACHE_ENV]!r}"
                )
            with warnings.catch_warnings():  # restores Python's own printing afterwards
                warnings.showwarning = _one_line_warning
                if program:  # the command ends its own work on Ctrl-C (KeyboardInterrupt)
                    signal.signal(signal.SIGINT, interrupted)
                if as_program:
                    for name in ("SIGTERM", "SIGHUP"):  # a kill or a closed terminal alike
                        number = getattr(signal, name, None)
                        if number is not None and signal.getsignal(number) is signal.SIG_DFL:
                            signal.signal(number, interrupted)
                            caught.append(number)
                status = args.run(args)
            if received:  # a library swallowed the KeyboardInterrupt and the command went on
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                _log(
                    f"{command}: stopped by {signal.Signals(received[-1]).name} as it ended: "
                    "every file it wrote is whole, "
                    "but a step the interrupt cut short may be missing; run it again"
                )
                return 3
            return status
        except SessionAborted as stop:
            why = stop.args[0] if stop.args else "SIGINT"
            _log(f"{args.command}: stopped by {why}; nothing more was written")
            return 3
        except (KeyboardInterrupt, BrokenPipeError):
            raise
        except Exception as error:
            if received:  # raised by what the interrupt broke (a stream cut in a library)
                raise KeyboardInterrupt from error
            message = _refusal(error)
            if message is None:
                traceback.print_exc()
                print(f"glarelab {args.command}: {ISSUES}", file=sys.stderr)
                return 70
            print(f"glarelab {args.command}: {message}", file=sys.stderr)
            return 2
    except KeyboardInterrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C while cleaning up
        _forget_interrupt()
        # a session's own trials are on disk and its sidecar says how it ended; every other
        # file is written whole or not at all, so an interruption leaves the output as it was
        name = signal.Signals(received[-1]).name if received else "SIGINT"
        _log(f"{command}: stopped by {name}; nothing more was written")
        return 3
    except BrokenPipeError:
        _quiet_stdout()
        return 0
    finally:
        for number in caught:
            signal.signal(number, signal.SIG_DFL)
        if args is not None and args.no_cache:
            if previous is None:
                os.environ.pop(NO_CACHE_ENV, None)
            else:
                os.environ[NO_CACHE_ENV] = previous
        if program:  # Python shuts down next: a Ctrl-C then ends it at once, status 3
            stopping = signal.signal(signal.SIGINT, signal.SIG_IGN) is signal.SIG_IGN
            _forget_interrupt()  # one swallowed in a library would make Python kill itself
            for stream in (sys.stdout, sys.stderr):  # os._exit would lose what is buffered
                with contextlib.suppress(OSError, ValueError):
                    stream.flush()
            if not stopping:
                signal.signal(signal.SIGINT, _stopped_while_ending)


if __name__ == "__main__":
    sys.exit(main())
