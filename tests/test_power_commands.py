"""glarelab power and sweep as a user runs them: killed and resumed, against a Dask cluster
started apart (their bad inputs are in tests/test_bad_inputs.py)."""

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil

from glarelab.cli import main

BIN = Path(sys.executable).parent
TINY = ["luidolt2020", "--participants", "4", "7", "--seed", "3"]


def _stop(process):
    """End a process we started, and its children, by id."""
    try:
        children = psutil.Process(process.pid).children(recursive=True)
    except psutil.NoSuchProcess:
        children = []
    for child in children:
        try:
            child.kill()
        except psutil.NoSuchProcess:
            pass
    process.kill()
    process.wait(timeout=30)
    psutil.wait_procs(children, timeout=30)


def test_a_killed_power_run_resumes_to_the_uninterrupted_result(tmp_path):
    whole = tmp_path / "whole"
    assert (
        main(["power", *TINY, "--replications", "8", "--workers", "1", "--out", str(whole)]) == 0
    )
    killed = tmp_path / "killed"
    process = subprocess.Popen(
        [
            str(BIN / "glarelab"),
            "power",
            *TINY,
            "--replications",
            "8",
            "--workers",
            "1",
            "--out",
            str(killed),
            "--task-delay-ms",
            "700",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    log = killed / "replications.jsonl"
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline and (
        not log.is_file() or len(log.read_bytes().splitlines()) < 3
    ):
        time.sleep(0.2)
    workers = psutil.Process(process.pid).children(recursive=True)
    for child in [*workers, psutil.Process(process.pid)]:
        child.send_signal(signal.SIGKILL)  # SIGKILL mid-way: no handler runs
    process.wait(timeout=30)
    psutil.wait_procs(workers, timeout=30)
    done = len(log.read_bytes().splitlines())
    assert 3 <= done < 8 and not (killed / "power.csv").exists()
    assert (
        main(["power", *TINY, "--replications", "8", "--workers", "1", "--out", str(killed)]) == 0
    )
    for name in ("power.csv", "effect_sizes.csv", "recommended.csv"):
        assert (killed / name).read_bytes() == (whole / name).read_bytes(), name
    assert len(log.read_bytes().splitlines()) == 8  # only the missing ones were run


def test_power_on_a_dask_cluster_started_apart(tmp_path):
    scheduler_file = tmp_path / "scheduler.json"
    scheduler = subprocess.Popen(
        [
            str(BIN / "dask"),
            "scheduler",
            "--host",
            "127.0.0.1",
            "--port",
            "0",
            "--no-dashboard",
            "--scheduler-file",
            str(scheduler_file),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    worker = None
    try:
        deadline = time.monotonic() + 60
        while not scheduler_file.is_file() and time.monotonic() < deadline:
            time.sleep(0.2)
        address = json.loads(scheduler_file.read_text())["address"]
        worker = subprocess.Popen(
            [
                str(BIN / "dask"),
                "worker",
                address,
                "--nthreads",
                "1",
                "--nworkers",
                "1",
                "--no-dashboard",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        outside, here = tmp_path / "outside", tmp_path / "here"
        args = [*TINY, "--replications", "4"]
        assert main(["power", *args, "--scheduler", address, "--out", str(outside)]) == 0
        assert main(["power", *args, "--workers", "0", "--out", str(here)]) == 0
        assert (outside / "power.csv").read_bytes() == (here / "power.csv").read_bytes()
    finally:
        for process in (worker, scheduler):
            if process is not None:
                _stop(process)


def test_a_scheduler_that_does_not_answer_is_refused_by_name(tmp_path, capsys, monkeypatch):
    import contextlib

    from glarelab.planning import execute

    @contextlib.contextmanager
    def unreachable(**kwargs):
        raise OSError("Timed out trying to connect to tcp://127.0.0.1:1 after 30 s")
        yield

    monkeypatch.setattr(execute, "dask_client", unreachable)
    args = ["luidolt2020", "--participants", "4", "--scheduler", "tcp://127.0.0.1:1"]
    assert main(["power", *args, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    # the address is probed before Dask is asked: nothing listens on port 1
    assert "--scheduler tcp://127.0.0.1:1: nothing answers at 127.0.0.1:1" in err, err
    assert not (tmp_path / "out").exists()


def test_sweep_command_prints_its_index(capsys, tmp_path):
    assert (
        main(
            [
                "sweep",
                "yoshida2008",
                "--set",
                "glare.l_dmax_cd_m2=200,220",
                "--workers",
                "0",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "glare.l_dmax_cd_m2" in printed and (tmp_path / "index.csv").is_file()
