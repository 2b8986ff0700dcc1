"""Let a serial driver set an RS-232 line's settings on a pseudo-terminal.

A pseudo-terminal has no line: Linux refuses settings it cannot hold (7 data bits, parity:
``EINVAL``), so a driver that sets up the LS-100's 4800 baud, 7 data bits, even parity and 2
stop bits fails before its first byte. :func:`install` lets such a ``tcsetattr`` on a
pseudo-terminal through without those bits and writes what the driver asked for into
``FOLDER/<pts name>.json`` (the simulated device reads it, and answers garbage when the line is
set up wrong, as a real instrument does). Nothing else changes: the driver's own code runs.

``python -m tests.stimuli.pty_line FOLDER -m glarelab ARGS`` runs a command with it installed.
"""

from __future__ import annotations

import errno
import json
import os
import runpy
import sys
import termios
from pathlib import Path

_SPEEDS = {
    getattr(termios, f"B{rate}"): rate
    for rate in (1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200)
}


def line_settings(attributes) -> dict:
    cflag = attributes[2]
    bits = {termios.CS5: 5, termios.CS6: 6, termios.CS7: 7, termios.CS8: 8}[cflag & termios.CSIZE]
    parity = "N"
    if cflag & termios.PARENB:
        parity = "O" if cflag & termios.PARODD else "E"
    return {
        "baud": _SPEEDS.get(attributes[5], attributes[5]),
        "line": f"{bits}{parity}{2 if cflag & termios.CSTOPB else 1}",
    }


def keeping_tcsetattr(folder: Path, real=termios.tcsetattr):
    """A ``termios.tcsetattr`` that lets a pseudo-terminal be set up as a serial line."""
    folder = Path(folder)

    def tcsetattr(fd, when, attributes):
        try:
            name = os.ttyname(fd)
        except OSError:
            name = ""
        if name.startswith("/dev/pts/"):
            (folder / f"{Path(name).name}.json").write_text(json.dumps(line_settings(attributes)))
        try:
            return real(fd, when, attributes)
        except termios.error as error:
            if error.args[0] != errno.EINVAL or not name.startswith("/dev/pts/"):
                raise
            held = list(attributes)
            held[2] = (held[2] & ~(termios.CSIZE | termios.PARENB | termios.PARODD)) | termios.CS8
            return real(fd, when, held)

    return tcsetattr


def install(folder: Path) -> None:
    termios.tcsetattr = keeping_tcsetattr(folder)


if __name__ == "__main__":
    install(Path(sys.argv[1]))
    if sys.argv[2] != "-m":
        raise SystemExit("usage: python -m tests.stimuli.pty_line FOLDER -m MODULE ARGS")
    sys.argv = [sys.argv[3], *sys.argv[4:]]
    runpy.run_module(sys.argv[0], run_name="__main__", alter_sys=True)
