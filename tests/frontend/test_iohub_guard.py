"""The guard of a session's ioHub server, with stand-ins for both (no screen): when the session
dies (a zombie not yet reaped counts as dead), the server it launched is asked to stop as its
client would ask, and killed if it does not; a server of another process is left alone."""

import subprocess
import sys
import threading

import pytest

from glarelab.frontend import iohub_guard

REQUEST = b"\x91\xb1STOP_IOHUB_SERVER"  # msgpack of ("STOP_IOHUB_SERVER",), as ioHub packs it
SERVER = """
import socket, sys, time
port, deaf = int(sys.argv[1]), sys.argv[2] == "deaf"
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
sock.bind(("127.0.0.1", port))
print("up", flush=True)
while True:
    data, _ = sock.recvfrom(64)
    if data == {request!r} and not deaf:
        sys.exit(0)
"""


def _free_port() -> int:
    from glarelab.frontend.eyetracker import _free_udp_port

    return _free_udp_port()


@pytest.mark.parametrize(("deaf", "expected"), [(False, "stopped"), (True, "killed")])
def test_a_dead_sessions_server_is_stopped_or_killed(tmp_path, monkeypatch, deaf, expected):
    monkeypatch.setattr(iohub_guard, "STOP_GRACE_S", 1.0)
    script = tmp_path / iohub_guard.SERVER_SCRIPT  # the name ioHub's server runs under
    script.write_text(SERVER.format(request=REQUEST))
    session = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    other = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    port, other_port = _free_port(), _free_port()
    servers = [
        subprocess.Popen(
            [sys.executable, str(script), str(p), "deaf" if deaf else "hears", str(owner.pid)],
            stdout=subprocess.PIPE,
            text=True,
        )
        for p, owner in ((port, session), (other_port, other))
    ]
    try:
        for server in servers:
            assert server.stdout.readline() == "up\n"
        result = []
        guard = threading.Thread(
            target=lambda: result.append(iohub_guard.watch(session.pid, port, REQUEST))
        )
        guard.start()
        session.kill()  # not reaped: a zombie, dead all the same
        guard.join(timeout=20)
        assert result == [expected]
        assert servers[0].wait(timeout=5) == (0 if not deaf else -9)
        assert servers[1].poll() is None  # another process's server: left alone
    finally:
        for process in (session, other, *servers):
            process.kill()
            process.wait()


def test_a_guard_of_a_session_that_left_no_server_ends_at_once():
    session = subprocess.Popen([sys.executable, "-c", "pass"])
    session.wait()
    assert iohub_guard.watch(session.pid, _free_port(), REQUEST) == "none left"
