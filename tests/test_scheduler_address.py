"""``glarelab power --scheduler`` says what answers at an address that is not a Dask
scheduler (a web server such as Dask's own dashboard, or nothing) instead of hanging or
running out of memory on HTTP bytes read as a Dask frame; a real scheduler passes."""

from __future__ import annotations

import http.server
import subprocess
import sys
import threading

import pytest

from glarelab.commands.power import scheduler_problem


@pytest.fixture
def web_server():
    server = http.server.ThreadingHTTPServer(
        ("127.0.0.1", 0), http.server.SimpleHTTPRequestHandler
    )
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"tcp://127.0.0.1:{server.server_address[1]}"
    server.shutdown()
    server.server_close()


def test_a_web_server_is_named_as_one(web_server):
    problem = scheduler_problem(web_server, wait_s=0.5)
    assert problem is not None and "is a web server (HTTP/1.0" in problem
    assert "8786" in problem


def test_a_dask_scheduler_passes():
    from distributed import LocalCluster

    with LocalCluster(n_workers=0, processes=False, dashboard_address=None) as cluster:
        assert scheduler_problem(cluster.scheduler_address) is None


def test_nothing_listening_is_said():
    assert scheduler_problem("tcp://127.0.0.1:1").startswith("nothing answers at 127.0.0.1:1")


def test_the_command_refuses_a_web_server_in_one_line(web_server, tmp_path):
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "power", "yoshida2008", "--participants", "6",
         "--replications", "2", "--scheduler", web_server, "--out", str(tmp_path / "power")],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode != 0
    last = done.stderr.strip().splitlines()[-1]
    assert "is a web server" in last and "memory" not in done.stderr, done.stderr
