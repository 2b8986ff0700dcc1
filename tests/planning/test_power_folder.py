"""A power run's folder as a user keeps it: their own files in it survive a run, the
replications are kept and resumed across the swap of the folder, and a second run on the same
folder is refused while the first holds it (the kills are in tests/test_faults.py)."""

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import psutil

from glarelab.cli import main
from glarelab.files.folders import LISTING, listed_files
from glarelab.files.locks import ProcessLock

BIN = Path(sys.executable).parent
TINY = ["power", "luidolt2020", "--participants", "4", "--seed", "5", "--workers", "0"]


def everything(folder: Path) -> dict[str, bytes | str]:
    """Every entry under ``folder`` (hidden ones too): a file's bytes, a link's target."""
    found = {}
    for path in sorted(folder.rglob("*")):
        name = path.relative_to(folder).as_posix()
        if path.is_symlink():
            found[name] = f"-> {os.readlink(path)}"
        elif path.is_file():
            found[name] = path.read_bytes()
    return found


def test_a_users_files_in_the_folder_survive_a_run_and_the_replications_resume(tmp_path):
    out = tmp_path / "power"
    assert main([*TINY, "--replications", "2", "--out", str(out)]) == 0
    (out / "notes.txt").write_text("participant 3 wore glasses\n")
    (out / "drafts").mkdir()
    (out / "drafts" / "figure.svg").write_text("<svg/>\n")
    (out / "latest").symlink_to("power.csv")
    log = out / "replications.jsonl"
    first = log.read_bytes()
    assert main([*TINY, "--replications", "3", "--out", str(out)]) == 0
    assert (out / "notes.txt").read_text() == "participant 3 wore glasses\n"
    assert (out / "drafts" / "figure.svg").read_text() == "<svg/>\n"
    assert os.readlink(out / "latest") == "power.csv"
    assert log.read_bytes().startswith(first) and len(log.read_bytes().splitlines()) == 3
    assert set(pd.read_csv(out / "power.csv")["replications"]) == {3}  # the new summaries
    # the listing names glarelab's files, not the user's
    listed = listed_files(out)
    assert {"power.csv", "replications.jsonl", "run.json"} <= set(listed)
    assert not {"notes.txt", "drafts/figure.svg", "latest"} & set(listed)
    # after the swap the log is resumed, not restarted: a run of as many does no replication
    kept = everything(out)
    assert main([*TINY, "--replications", "3", "--out", str(out)]) == 0
    now = everything(out)
    assert now.keys() == kept.keys()
    assert {name: now[name] for name in now if name != LISTING} == {
        name: kept[name] for name in kept if name != LISTING
    }
    # nothing is left beside the folder: no staging folder, no lock
    assert sorted(p.name for p in tmp_path.iterdir()) == ["power"]


def test_a_second_run_on_a_folder_another_run_holds_is_refused_and_changes_nothing(
    tmp_path, capsys
):
    out = tmp_path / "power"
    assert main([*TINY, "--replications", "2", "--out", str(out)]) == 0
    before = everything(out)
    with ProcessLock(tmp_path / ".power.power.lock", refusal=RuntimeError):
        capsys.readouterr()
        status = main([*TINY, "--replications", "3", "--out", str(out)])
        err = capsys.readouterr().err
    assert status == 2, err
    assert "Traceback" not in err
    refusals = [line for line in err.splitlines() if line.startswith("glarelab ")]
    assert refusals == [
        f"glarelab power: {out} is in use by another glarelab power run (pid {os.getpid()} on "
        f"{socket.gethostname()}): wait for it to end, or give another --out (nothing was "
        "changed)"
    ], err
    assert everything(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["power"]  # the lock file went too


def test_a_run_started_while_another_process_runs_on_the_folder_names_that_process(
    tmp_path, capsys
):
    out = tmp_path / "power"
    slow = ["--replications", "2", "--task-delay-ms", "4000"]
    process = subprocess.Popen(
        [str(BIN / "glarelab"), *TINY, *slow, "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        lock = tmp_path / ".power.power.lock"
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and not (
            lock.is_file() and lock.read_text().startswith("pid ")
        ):
            assert process.poll() is None, "the first run ended before it took the folder"
            time.sleep(0.05)
        capsys.readouterr()
        status = main([*TINY, "--replications", "2", "--out", str(out)])
        err = capsys.readouterr().err
        assert status == 2, err
        assert f"(pid {process.pid} on {socket.gethostname()})" in err, err
        assert len([line for line in err.splitlines() if line.startswith("glarelab ")]) == 1
        assert process.poll() is None  # the first run goes on
    finally:
        try:
            children = psutil.Process(process.pid).children(recursive=True)
        except psutil.NoSuchProcess:
            children = []
        process.kill()
        process.wait(timeout=30)
        for child in children:
            if child.is_running():
                child.kill()
    # the next run, with the first one gone, takes the folder (the kill left its lock file)
    assert main([*TINY, "--replications", "2", "--out", str(out)]) == 0
    assert (out / "power.csv").is_file()


def test_a_resume_on_another_stimulus_set_is_refused(tmp_path, capsys):
    """A run resumed with another --stimuli (the same protocol built with another
    calibration) mixed its replications with the first set's: run.json now records the
    set's manifest, and a resume on another set is refused as one with another seed is."""
    import json

    out = tmp_path / "power"
    shown = ["power", "yoshida2008", "--participants", "3", "--seed", "5", "--workers", "0"]
    assert main([*shown, "--replications", "1", "--out", str(out)]) == 0
    run = json.loads((out / "run.json").read_text())
    assert len(run["stimuli_sha256"]) == 64  # the cached set the observers looked at
    run["stimuli_sha256"] = "0" * 64  # as if made with another set
    (out / "run.json").write_text(json.dumps(run, indent=2, sort_keys=True) + "\n")
    before = (out / "replications.jsonl").read_text()
    capsys.readouterr()
    assert main([*shown, "--replications", "2", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "made with other inputs (stimuli_sha256 '000" in err, err
    assert (out / "replications.jsonl").read_text() == before
