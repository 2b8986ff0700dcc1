"""Stop a session's ioHub server when the session ends without stopping it (killed, crashed).

PsychoPy's ioHub server watches the process that launched it, but when that process is gone it
only shuts its devices down and keeps serving its UDP port: the server process never ends
(PsychoPy 2024-2025: ``ioServer.checkForPsychopyProcess`` calls ``shutdown`` but not the UDP
server's ``stop``, which only the client's ``STOP_IOHUB_SERVER`` request does). An orphaned
server holds the terminal, the output pipe of whoever started the session, and the session's
hdf5 store.

The guard is a process of its own, started before the server (:func:`start_guard`), so that no
moment of the launch is unguarded. It waits for the session to end; then it finds the session's
servers (``start_iohub_process.py`` started after the session, whose last argument, the
process ioHub watches, is the session's id), sends them the request their client would have
sent (so that they close their store as on a normal quit) and kills those not ended
:data:`STOP_GRACE_S` later. A session that quits its server stops its guard
(:meth:`glarelab.frontend.eyetracker.IoHubEyeTracker.close`).

The guard runs as a script (``python -I iohub_guard.py SESSION_PID PORT REQUEST_HEX``),
importing only the standard library and psutil; it ignores Ctrl-C (the session handles it and
quits its server itself) and writes nothing.
"""

from __future__ import annotations

import contextlib
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

__all__ = ["POLL_S", "SERVER_SCRIPT", "STOP_GRACE_S", "servers_of", "start_guard", "watch"]

POLL_S = 0.2  # how often the guard looks at the session and its servers
# how long a server may take to close its store after the stop request before it is killed
# (an assumption: ioHub closes its devices and hdf5 file in well under a second)
STOP_GRACE_S = 5.0
SERVER_SCRIPT = "start_iohub_process.py"  # what ioHub's launchHubServer runs


def _alive(process) -> bool:
    """Whether a psutil process still runs (a zombie, dead but not yet reaped, does not)."""
    import psutil

    try:
        return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False


def servers_of(session_pid: int, *, since: float = 0.0) -> list:
    """The ioHub servers launched by the process ``session_pid``, running now.

    Parameters
    ----------
    session_pid
        The launching process's id (ioHub's server is given it as its last argument, the
        process it watches).
    since
        Only servers started at or after this time (the session's start, s since the epoch:
        not those of an earlier process of the same id).

    Returns
    -------
    list of psutil.Process
    """
    import psutil

    found = []
    for process in psutil.process_iter(["cmdline", "create_time"]):
        command = process.info["cmdline"] or []
        if (
            len(command) >= 2
            and any(Path(part).name == SERVER_SCRIPT for part in command[:2])
            and command[-1] == str(session_pid)
            and (process.info["create_time"] or 0.0) >= since
            and _alive(process)
        ):
            found.append(process)
    return found


def watch(session_pid: int, port: int, request: bytes) -> str:
    """Wait until the session ends; then stop the ioHub servers it left running.

    Parameters
    ----------
    session_pid
        The session's process (the one that launches the servers).
    port
        The servers' UDP port (on this machine).
    request
        The ``STOP_IOHUB_SERVER`` request as ioHub's client packs it.

    Returns
    -------
    str
        ``'none left'``, ``'stopped'`` (they ended on the request) or ``'killed'``.
    """
    import psutil

    try:
        session = psutil.Process(session_pid)
        since = session.create_time()
    except psutil.Error:  # already gone: its servers are those started since a moment ago
        session, since = None, time.time() - 60.0
    while session is not None and _alive(session):
        time.sleep(POLL_S)
    left = servers_of(session_pid, since=since)
    if not left:
        return "none left"
    with contextlib.suppress(OSError), socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.sendto(request, ("127.0.0.1", port))
    deadline = time.monotonic() + STOP_GRACE_S
    while any(_alive(p) for p in left) and time.monotonic() < deadline:
        time.sleep(POLL_S / 4)
    if not any(_alive(p) for p in left):
        return "stopped"
    for process in left:
        with contextlib.suppress(psutil.Error):
            process.kill()
    return "killed"


def start_guard(port: int, request: bytes) -> subprocess.Popen:
    """Start the guard of the ioHub server this process is about to launch (a process of its
    own, silent; it ignores Ctrl-C).

    Parameters
    ----------
    port
        The server's UDP port.
    request
        The ``STOP_IOHUB_SERVER`` request as ioHub's client packs it.

    Returns
    -------
    subprocess.Popen
        The guard; stop it (``kill``) once the server is quit.
    """
    return subprocess.Popen(
        [sys.executable, "-I", str(Path(__file__)), str(os.getpid()), str(port), request.hex()],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the session's to handle
    watch(int(sys.argv[1]), int(sys.argv[2]), bytes.fromhex(sys.argv[3]))
