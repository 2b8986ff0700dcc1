"""``python -m glarelab`` and the ``glarelab`` script: :func:`glarelab.cli.main`, with Ctrl-C
ending the program with status 3 and one line from its first instant.

While the program starts (its imports, the parser: up to a second or two) nothing has been
done, so a Ctrl-C then ends it at once, without raising KeyboardInterrupt into library code
that might swallow it or print its traceback; :func:`glarelab.cli.main` then lets the command
see KeyboardInterrupt, to end its work as the module docstring of :mod:`glarelab.cli` says.
"""

import _signal  # the signal module's C part: ``signal`` itself imports enum, 10-50 ms
import atexit
import os
import sys

__all__ = ["main"]


def _stopped_while_starting(number: int, frame: object) -> None:
    """SIGINT before the command runs: nothing was done, end at once (a signal handler)."""
    os.write(2, b"[glarelab] stopped by SIGINT while starting; nothing was done\n")
    os._exit(3)


def _ignore_sigint_in_teardown() -> None:
    """The last exit handler (registered first): after it Python puts SIGINT back to the
    system's default and tears its modules down, and a Ctrl-C then would kill the finished
    program (status -2 to the shell, not 3); ignored, it ends with the status it chose."""
    _signal.signal(_signal.SIGINT, _signal.SIG_IGN)


def main() -> int:
    """Run the ``glarelab`` program with :data:`sys.argv`; returns its exit status."""
    atexit.register(_ignore_sigint_in_teardown)  # first registered, last run
    if _signal.getsignal(_signal.SIGINT) is not _signal.SIG_IGN:  # ignored: a background job
        _signal.signal(_signal.SIGINT, _stopped_while_starting)
    from glarelab.cli import main as run

    return run()


if __name__ == "__main__":
    sys.exit(main())
