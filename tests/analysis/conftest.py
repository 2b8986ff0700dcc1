"""Simulated sessions of the three paper studies, run once for the analysis tests (their
stimulus sets are built into the test run's cache, where :func:`cached_stimulus_set` finds
them)."""

import subprocess
import sys

import pytest


@pytest.fixture(scope="session")
def simulated(tmp_path_factory, stimulus_set_cache):
    folder = tmp_path_factory.mktemp("sessions")
    for study in ("yoshida2008", "spencer1995", "luidolt2020"):
        done = subprocess.run(
            [sys.executable, "-m", "glarelab", "run", study, "--simulate", "--participants",
             "10", "--seed", "1", "--out", str(folder)],
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
    return folder


@pytest.fixture(scope="session")
def reports(simulated, tmp_path_factory):
    """The reports of the three paper studies' simulated sessions (their folders)."""
    from glarelab.analysis.report import write_report
    from glarelab.protocols import load_protocol

    folder = tmp_path_factory.mktemp("reports")
    written = {}
    for study in ("yoshida2008", "spencer1995", "luidolt2020"):
        files = sorted(simulated.glob(f"*_{study}_s1_*.csv"))
        written[study] = write_report(load_protocol(study), files, folder / study).parent
    return written
