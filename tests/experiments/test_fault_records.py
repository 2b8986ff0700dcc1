"""What the session files say when a session is killed, resumed, paused or stopped at once,
driven as a participant drives it: a real window on an X server and real key events (xdotool).
Breaks and Escape during a flash are in test_pilot.py (one Spencer session shows both)."""

import csv
import re
import time
from pathlib import Path

import pytest
from PIL import Image

from .xscreen import XScreen, sidecar_of


@pytest.fixture
def screen(tmp_path):
    x = XScreen(tmp_path)
    yield x
    x.close()


def session_csv(folder: Path) -> Path:
    (path,) = sorted(Path(folder).glob("*.csv"))
    return path


def rows_of(path: Path) -> list[dict]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def test_killed_runs_resume_with_a_truthful_record(screen, tmp_path):
    out = tmp_path / "data"
    run = ("run", "luidolt2020", "--participant", "P01", "--out", out)
    screen.run(*run)
    screen.wait_for_log(out, r"session log")
    screen.focus_window()
    time.sleep(0.3)
    screen.key("space")
    screen.wait_for_log(out, r"trial 1 onset")
    screen.key("4")
    screen.wait_for_log(out, r"screen comment of trial 1")
    # Shift+Enter is a new line in the comment, not its end: the 5 after it is typed text,
    # not the next category's rating
    screen.type("one")
    screen.key("shift+Return")
    screen.type("5 two")
    time.sleep(0.3)
    Image.fromarray(screen.screenshot()).save(tmp_path / "comment_two_lines.png")
    screen.key("Return")
    screen.wait_for_log(out, r"trial 2 onset")
    screen.key("5")
    screen.wait_for_log(out, r"screen comment of trial 2")
    screen.process.kill()  # killed outright: no end written
    screen.wait()
    path = session_csv(out)
    assert sidecar_of(path)["status"] == "running"

    screen.run(*run, "--resume")  # a second run, killed before any trial of its own
    screen.wait_for_log(out, r"session log", count=2)
    time.sleep(1.1)  # its start a second later than the first run's last write
    screen.process.kill()
    screen.wait()

    screen.run(*run, "--resume")
    screen.wait_for_log(out, r"session log", count=3)
    time.sleep(0.3)
    Image.fromarray(screen.screenshot()).save(tmp_path / "continue.png")
    screen.key("space")
    screen.wait_for_log(out, r"continue screen offset at")
    screen.wait_for_log(out, r"trial 2 onset", count=2)
    screen.key("Escape")
    assert screen.wait() == 3, screen.stderr[-2000:]

    rows = rows_of(path)
    assert [(r["rating"], r["comment"]) for r in rows] == [("4", "one\n5 two")]
    sidecar = sidecar_of(path)
    first, second, third = sidecar["runs"]
    for killed in (first, second):
        assert killed["status"] == "interrupted"
        assert killed["ended"] is None and killed["ended_by"].startswith("unknown")
        assert killed["trials_after"] == 1  # counted from the CSV when the next run started
        assert killed["last_write"] >= killed["started"]  # never before its own start
    assert second["trials_before"] == 1
    assert third["status"] == "aborted" and third["ended"] >= third["started"]
    log = path.with_suffix(".log").read_text()
    # the log's clock restarts with every run: each begins with its wall-clock marker
    markers = re.findall(r"run (\d) started (\S+); log time 0 = Unix time ([\d.]+) s", log)
    assert [m[0] for m in markers] == ["1", "2", "3"]
    assert [m[1] for m in markers] == [r["started"] for r in sidecar["runs"]]
    assert float(markers[2][2]) == pytest.approx(third["clock_epoch_s"], abs=1e-3)
    assert "continue screen onset at" in log and "instructions screen offset at" in log
    frames = path.parent / (path.stem + "_frames.tsv")
    runs = [line for line in frames.read_text().splitlines() if line.startswith("run ")]
    assert [line.split()[1] for line in runs] == ["1", "2", "3"]


def test_the_dialog_asks_again_after_a_bad_entry_and_escape_before_a_trial_keeps_the_run(
    screen, tmp_path
):
    out = tmp_path / "data"
    screen.run("run", "luidolt2020", "--out", out)
    screen.focus_window("glarelab luidolt2020")
    time.sleep(0.5)
    screen.type("P09")
    screen.key("Tab", "Tab")
    screen.type("abc")  # not an age
    screen.key("Return")
    time.sleep(1.5)  # the dialog again, naming the problem, what was typed kept
    shown = screen.screenshot()
    Image.fromarray(shown).save(tmp_path / "dialog_again.png")
    screen.focus_window("glarelab luidolt2020")
    # the dialog asks again with the participant's field focused: Tab, Tab to the age (by the
    # keys a person uses: where the field lands on the screen depends on the fonts installed)
    screen.key("Tab", "Tab", "ctrl+a")
    screen.type("31")
    screen.key("Return")
    screen.wait_for_log(out, r"instructions screen onset")
    screen.key("Escape")  # before the first trial: the run is kept, aborted
    assert screen.wait() == 3, screen.stderr[-2000:]
    assert "0 trials, aborted (escape)" in screen.stderr
    (path,) = out.glob("P09_luidolt2020_s1_*.csv")
    assert rows_of(path) == []  # the header, no trial
    sidecar = sidecar_of(path)
    assert sidecar["participant_info"]["age"] == 31
    assert sidecar["status"] == "aborted" and sidecar["trials"] == 0
    assert sidecar["runs"][0]["ended_by"] == "escape" and sidecar["ended"] >= sidecar["started"]
    log = path.with_suffix(".log").read_text()
    assert "instructions screen onset" in log and "escape at" in log


def test_a_display_that_goes_away_ends_the_session_as_aborted(screen, tmp_path):
    """The X server killed mid-session (a remote session closed, a crash): the process ended
    with a segmentation fault (exit 139), its sidecar still 'running', its lock and reserve
    left; it ends as a stop does (exit 3), aborted, every finished trial kept."""
    out = tmp_path / "data"
    screen.run("run", "luidolt2020", "--participant", "P01", "--out", out)
    screen.wait_for_log(out, r"session log")
    screen.focus_window()
    time.sleep(0.3)
    screen.key("space")
    screen.wait_for_log(out, r"trial 1 onset")
    screen.key("5")
    screen.wait_for_log(out, r"screen comment of trial 1")
    screen.key("Return")
    screen.wait_for_log(out, r"trial 2 onset")
    screen.server.kill()  # the display goes, the session's window with it
    screen.server.wait(timeout=30)
    assert screen.wait() == 3, screen.stderr[-2000:]
    assert "the X display was lost" in screen.stderr and "Traceback" not in screen.stderr
    path = session_csv(out)
    sidecar = sidecar_of(path)
    assert sidecar["status"] == "aborted" and sidecar["trials"] == 1
    assert sidecar["runs"][-1]["ended_by"].startswith("display lost")
    assert [r["rating"] for r in rows_of(path)] == ["5"]
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == []  # no reserve
