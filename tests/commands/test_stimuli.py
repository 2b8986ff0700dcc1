"""``glarelab stimuli verify`` clears what a killed build left beside the set: its hidden
staging folder, and the earlier set it had moved aside (put back)."""

from __future__ import annotations

import subprocess
import sys

from glarelab.cli import main


def _dead_pid() -> int:
    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    return int(done.stdout)


def test_verify_removes_a_killed_builds_staging_folder(tmp_path, capsys):
    """A rebuild killed by SIGKILL left ``.set.building-PID`` (a partial set) beside the set
    until the next build."""
    folder = tmp_path / "set"
    folder.mkdir()
    staging = tmp_path / f".set.building-{_dead_pid()}"
    staging.mkdir()
    (staging / "reference_A.exr").write_bytes(b"half")
    main(["stimuli", "verify", str(folder)])  # not a set: refused, yet the leftover cleared
    assert not staging.exists() and folder.is_dir()


def test_verify_puts_back_a_set_a_killed_build_left_aside(tmp_path, capsys):
    aside = tmp_path / f".set.old-{_dead_pid()}"
    aside.mkdir()
    (aside / "manifest.json").write_text("{}")
    main(["stimuli", "verify", str(tmp_path / "set")])
    assert (tmp_path / "set" / "manifest.json").read_text() == "{}" and not aside.exists()
    assert "no such folder" not in capsys.readouterr().err
