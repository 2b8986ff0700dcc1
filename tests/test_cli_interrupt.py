"""Ctrl-C ends the ``glarelab`` program with status 3, one line and no traceback, whenever it
comes: while Python imports the command (the first second of ``stimuli build`` and
``analyse``), while the command runs, and through an ``eval`` of a string (as
``collections.namedtuple`` does at import), after which CPython would otherwise kill itself by
SIGINT (status -2) instead of returning 3; also where a library swallows the KeyboardInterrupt
or fails for what it cut, and at the very end, as Python tears its modules down."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
# after the interpreter's own start (its site-packages' .pth files: 20-30 ms here), before
# any glarelab code, Python's default handler prints a traceback from ``site``: not ours
DELAYS_S = (0.05, 0.15, 0.25, 0.35, 0.5, 0.7)


def _terminal_sigint() -> None:
    """Ctrl-C as a terminal delivers it: a test runner started in the background of a shell
    has SIGINT ignored, and its children would inherit that (and keep it, as glarelab does)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize(
    "command",
    [
        ["stimuli", "build", "yoshida2008", "--out"],
        ["analyse", "yoshida2008", "no-such-session.csv", "--out"],
    ],
    ids=["stimuli-build", "analyse"],
)
def test_ctrl_c_while_starting_ends_with_3_and_one_line(command, tmp_path):
    started = []
    for number, delay in enumerate(DELAYS_S):  # all at once: the test takes under 2 s
        process = subprocess.Popen(
            [sys.executable, "-m", "glarelab", *command, str(tmp_path / f"out{number}")],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=ENV,
            cwd=tmp_path,
            preexec_fn=_terminal_sigint,
        )
        started.append((time.monotonic() + delay, process))
    for when, process in started:
        time.sleep(max(0.0, when - time.monotonic()))
        process.send_signal(signal.SIGINT)
    landed = 0
    for delay, (_, process) in zip(DELAYS_S, started, strict=True):
        _, err = process.communicate(timeout=60)
        lines = err.splitlines()
        if process.returncode != 3 and "glarelab" not in err:
            continue  # in the interpreter's own start, before any glarelab code, on a loaded
            # machine (killed in silence, or a traceback from site, runpy): not ours
        if process.returncode == 2 and lines[-1:] == ["  - no-such-session.csv: no such file"]:
            continue  # the command had refused its missing input and ended before the signal
        landed += 1
        assert process.returncode == 3, (delay, process.returncode, err)
        assert "Traceback" not in err and len(lines) == 1, (delay, err)
        assert "stopped by SIGINT" in lines[0], (delay, err)
    assert landed >= 3, "the machine is too slow to reach glarelab's start-up in time"
    assert not list(tmp_path.glob("out*"))  # nothing written


def test_an_interrupt_through_eval_still_ends_with_3(tmp_path):
    # the command is interrupted inside an eval of a string, as an import is in namedtuple;
    # run as ``python -m`` runs glarelab, the one way CPython then checks what it remembered
    (tmp_path / "interrupted_glarelab.py").write_text(
        textwrap.dedent(
            """
            import sys
            from glarelab import cli
            from glarelab.commands import load

            def interrupted(args):
                eval("(_ for _ in ()).throw(KeyboardInterrupt)")

            load("protocol")._protocol_check = interrupted
            sys.exit(cli.main(["protocol", "check", "yoshida2008"]))
            """
        )
    )
    done = subprocess.run(
        [sys.executable, "-m", "interrupted_glarelab"],
        capture_output=True,
        text=True,
        env=ENV,
        cwd=tmp_path,
    )
    assert done.returncode == 3, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr and "stopped by SIGINT" in done.stderr, done.stderr


SWALLOWING = """
import os, signal, sys, time
from glarelab import __main__ as entry
from glarelab.commands import load

def interrupt_here():
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(1.0)  # the handler runs in the meantime

def swallowed(args):  # a library that catches BaseException and goes on
    try:
        interrupt_here()
    except BaseException:
        pass
    return 0

def broken(args):  # the interrupt cut a library's stream, which then fails (zlib.error)
    try:
        interrupt_here()
    except BaseException:
        raise RuntimeError("Error -2 while flushing: inconsistent stream state") from None

class Late:
    def __del__(self):  # runs as Python tears its modules down, SIGINT back at its default
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.2)

def finished(args):
    sys.modules["late_holder"] = holder = type(sys)("late_holder")
    holder.late = Late()
    return 0

load("protocol")._protocol_check = {"swallowed": swallowed, "broken": broken,
                                    "finished": finished}[sys.argv.pop()]
sys.argv = ["glarelab", "protocol", "check", "yoshida2008"]
sys.exit(entry.main())
"""


@pytest.mark.parametrize(
    ("case", "status", "said"),
    [
        ("swallowed", 3, "stopped by SIGINT as it ended"),
        ("broken", 3, "protocol: stopped by SIGINT; nothing more was written"),
        ("finished", 0, ""),  # Ctrl-C after the command finished, while Python tears down
    ],
)
def test_an_interrupt_a_library_swallows_or_that_comes_at_exit_ends_as_the_command_chose(
    tmp_path, case, status, said
):
    (tmp_path / "swallowing_glarelab.py").write_text(SWALLOWING)
    done = subprocess.run(
        [sys.executable, "-m", "swallowing_glarelab", case],
        capture_output=True,
        text=True,
        env=ENV,
        cwd=tmp_path,
        preexec_fn=_terminal_sigint,
    )
    assert done.returncode == status, (done.returncode, done.stderr)
    assert "Traceback" not in done.stderr and said in done.stderr, done.stderr


def _terminal_signals() -> None:
    """SIGINT and SIGHUP as a terminal delivers them: a test runner started with nohup has
    SIGHUP ignored, and glarelab keeps what its parent ignores (as for SIGINT)."""
    _terminal_sigint()
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


def _background_job() -> None:
    """As a shell script's ``cmd &`` starts a job: SIGINT ignored, SIGTERM at its default."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


@pytest.mark.parametrize(
    ("number", "start"),
    [(signal.SIGTERM, _terminal_signals), (signal.SIGHUP, _terminal_signals),
     (signal.SIGTERM, _background_job)],
    ids=["SIGTERM", "SIGHUP", "SIGTERM-to-a-background-job"],
)  # fmt: skip
def test_a_kill_or_a_closed_terminal_during_a_build_ends_it_as_ctrl_c_does(
    number, start, tmp_path
):
    """SIGTERM (a kill, a job manager) ended a build at once with Python's default: its
    half-built ``.set.building-PID`` stayed beside the set. Now it ends as Ctrl-C does:
    status 3, one line naming the signal, the staging folder removed; also for a job a script
    started in the background (SIGINT ignored), which had no handler at all."""
    out = tmp_path / "set"
    process = subprocess.Popen(
        [sys.executable, "-m", "glarelab", "stimuli", "build", "yoshida2008", "--out", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=tmp_path,
        preexec_fn=start,
    )  # fmt: skip
    deadline = time.monotonic() + 120
    while not list(tmp_path.glob(".set.building-*")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list(tmp_path.glob(".set.building-*")), "the build never started"
    time.sleep(0.5)  # into its rendering
    process.send_signal(number)
    _, err = process.communicate(timeout=120)
    name = signal.Signals(number).name
    assert process.returncode == 3, (process.returncode, err)
    assert "Traceback" not in err and f"stopped by {name}; nothing more was written" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == [], sorted(tmp_path.iterdir())
