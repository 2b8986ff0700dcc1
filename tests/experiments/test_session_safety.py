"""Every refusal before the first trial shows its message and leaves the data as it was, and
no failure of the disk or of the process loses a recorded trial."""

import json
import resource
import signal
import subprocess
import sys
from datetime import datetime
from pathlib import Path

import pytest
from glarelab.experiments.data import SessionError, SessionFiles, session_files
from glarelab.experiments.display import DisplayMismatch, ScreenFacts
from glarelab.experiments.session import SimulatedFrontend, make_observer, run_session
from glarelab.protocols import load_protocol
from glarelab.stimuli.calibration import fit_calibration

from glarelab.cli import main

from .xscreen import XScreen

ROOT = Path(__file__).parents[2]
PROTOCOLS = ROOT / "protocols"
DATA = (".csv", ".json", ".log", ".tsv")


def data_files(folder: Path) -> dict[str, bytes]:
    """Every data file in a folder with its bytes (the lock file is not data)."""
    if not folder.exists():
        return {}
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.suffix in DATA}


def glarelab(*args, **options):
    return subprocess.run(
        [sys.executable, "-m", "glarelab", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        **options,
    )


def simulated(tmp_path, study="luidolt2020", participant="P01", *extra):
    return glarelab(
        "run", study, "--simulate", "--participant", participant, "--out", tmp_path, *extra
    )


@pytest.fixture(scope="module")
def stimulus_sets(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sets")
    for study in ("spencer1995", "yoshida2008"):
        protocol = str(PROTOCOLS / f"{study}.toml")
        assert main(["stimuli", "build", protocol, "--out", str(folder / study)]) == 0
    return folder


# --- the display and the calibration -----------------------------------------------------------


@pytest.mark.parametrize(
    ("study", "size", "refused"),
    [
        ("spencer1995", "1280 × 1024", ("resolution", "refresh")),
        ("yoshida2008", "2048 × 1536", ("resolution", "refresh", "bit-depth")),
    ],
)
def test_a_screen_that_is_not_the_protocols_display_is_refused(
    tmp_path, stimulus_sets, study, size, refused
):
    x = XScreen(tmp_path)
    try:
        out = tmp_path / "data"
        done = x.glarelab(
            "run", study, "--participant", "P01", "--stimuli", stimulus_sets / study,
            "--allow-uncalibrated", "--out", out,
        )  # fmt: skip
    finally:
        x.close()
    assert done.returncode == 2 and "Traceback" not in done.stderr
    message = done.stderr
    assert f"resolution: the protocol asks for {size} px, the display has 1920 × 1080 px" in (
        message
    )
    if "Hz measured" in message:  # Xvfb's refresh: hundreds of Hz, no vertical sync...
        options = f"--accept-mismatch {' '.join(refused)}"
    else:  # ...or no stable interval at all on a busy machine
        assert "refresh-unmeasured" in message and "--allow-unmeasured-refresh" in message
        options = f"--accept-mismatch {' '.join(r for r in refused if r != 'refresh')}"
    if "bit-depth" in refused:
        assert "bit-depth: the protocol asks for 10 bits per channel, the display has 8" in message
    assert options in message
    assert data_files(out) == {}


def test_a_calibration_of_another_display_is_refused_before_the_window(tmp_path, stimulus_sets):
    readings = [(c, 0.5 + 432.5 * (c / 1023) ** 2.2) for c in range(0, 1024, 31)] + [(1023, 433.0)]
    yoshida = fit_calibration(sorted(set(readings)), bit_depth=10, label="Barco, 433 cd/m²")
    path = yoshida.save(tmp_path / "barco.json")
    out = tmp_path / "data"
    with pytest.warns(UserWarning, match="not been verified"):
        with pytest.raises(DisplayMismatch) as refused:
            run_session(
                load_protocol("spencer1995"),
                "P01",
                out=out,
                frontend=_Unopenable(),
                stimuli=stimulus_sets / "spencer1995",
                calibration=yoshida,
            )
    message = str(refused.value)
    assert "calibration: the protocol asks for a 8-bit calibration with white 50 cd/m²" in message
    assert "a 10-bit calibration with white 433 cd/m² (Barco, 433 cd/m²)" in message
    assert "--accept-mismatch calibration" in message
    assert data_files(out) == {} and path.exists()


class _Unopenable:
    """A front-end that must not be opened: the refusal comes first."""

    def open(self):
        raise AssertionError("the window was opened before the calibration was checked")


class _Screen(SimulatedFrontend):
    """A simulated observer behind a screen with given facts."""

    def __init__(self, protocol, facts, stimuli):
        super().__init__(make_observer(protocol, "P01", seed=0, stimuli=stimuli))
        self.facts = facts

    def open(self):
        return self.facts


def test_a_failed_refresh_measurement_refuses_unless_allowed(tmp_path, stimulus_sets):
    protocol = load_protocol("yoshida2008")
    stimuli = stimulus_sets / "yoshida2008"
    display = protocol["display"]
    facts = ScreenFacts(tuple(display["resolution_px"]), None, 10)  # the protocol's, but...
    out = tmp_path / "data"
    with pytest.raises(DisplayMismatch, match="no stable frame interval") as refused:
        run_session(
            protocol,
            "P01",
            out=out,
            frontend=_Screen(protocol, facts, stimuli),
            stimuli=stimuli,
            simulated=True,
        )
    assert "--allow-unmeasured-refresh" in str(refused.value)
    assert data_files(out) == {}
    sidecar = run_session(
        protocol,
        "P01",
        out=out,
        frontend=_Screen(protocol, facts, stimuli),
        stimuli=stimuli,
        simulated=True,
        allow_unmeasured_refresh=True,
    )
    check = {c["name"]: c for c in sidecar["runs"][0]["checks"]}["refresh-unmeasured"]
    assert check["accepted"] and not check["passed"]
    assert sidecar["runs"][0]["display"]["frame_pacing"] == "clock"
    assert sidecar["refresh_hz"] == display["refresh_hz"]  # timed at the protocol's rate


# --- resuming ---------------------------------------------------------------------------------


def test_a_resume_with_another_protocol_is_refused(tmp_path):
    assert simulated(tmp_path, "yoshida2008", "P01").returncode == 0
    (sidecar,) = tmp_path.glob("*.json")  # as if it had ended with Escape
    sidecar.write_text(sidecar.read_text().replace('"status": "completed"', '"status": "aborted"'))
    before = data_files(tmp_path)
    changed = tmp_path / "changed.toml"
    changed.write_text(
        (PROTOCOLS / "yoshida2008.toml")
        .read_text()
        .replace("fine_step_cd_m2 = 1.0", "fine_step_cd_m2 = 2.0")
    )
    done = simulated(tmp_path, "yoshida2008", "P01", "--resume", "--protocol", changed)
    assert done.returncode == 2
    assert "was started with other inputs: the protocol (sha256" in done.stderr
    assert data_files(tmp_path) == before


@pytest.mark.parametrize("content", [b"", b"study,participant\n", b"trial 1 lost its header"])
def test_a_session_without_a_valid_header_is_not_resumed(tmp_path, content):
    csv = tmp_path / "P01_luidolt2020_s1_2026-11-30_1432.csv"
    csv.write_bytes(content)
    csv.with_suffix(".json").write_text("{}")
    before = data_files(tmp_path)
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 2 and "has no valid luidolt2020 header" in done.stderr
    assert "start a new session number" in done.stderr
    assert data_files(tmp_path) == before


def test_a_new_session_refuses_when_any_file_of_it_exists(tmp_path):
    (tmp_path / "P01_luidolt2020_s1_2025-01-01_0900.json").write_text("{}")
    before = data_files(tmp_path)
    done = simulated(tmp_path)
    assert done.returncode == 2 and "already has data" in done.stderr
    assert data_files(tmp_path) == before


def test_a_session_held_by_another_process_is_refused(tmp_path):
    files = SessionFiles(
        load_protocol("luidolt2020"), "P01", 1, tmp_path, resume=False, started=datetime.now()
    )
    try:
        with pytest.raises(SessionError, match=r"in use by another process \(pid \d+ on"):
            SessionFiles(
                load_protocol("luidolt2020"),
                "P01",
                1,
                tmp_path,
                resume=False,
                started=datetime.now(),
            )
        done = simulated(tmp_path)
        assert done.returncode == 2 and "in use by another process" in done.stderr
    finally:
        files.close()
    assert data_files(tmp_path) == {}
    assert simulated(tmp_path).returncode == 0  # released: the session can start now


# --- the disk and the process -----------------------------------------------------------------


def _small_disk():
    """The session process may write only a few bytes per file (a full disk)."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (16, 16))


def test_a_full_disk_at_the_start_leaves_no_file(tmp_path):
    done = glarelab(
        "run", "luidolt2020", "--simulate", "--participant", "P01", "--out", tmp_path,
        preexec_fn=_small_disk,
    )  # fmt: skip
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert "the session did not start and left no file" in done.stderr
    assert session_files(tmp_path, "P01", "luidolt2020", 1) == []


def test_the_header_and_sidecar_are_on_disk_before_the_first_trial(tmp_path):
    protocol = load_protocol("luidolt2020")
    seen = {}

    class Watching(SimulatedFrontend):
        def wait_keys(self, anchor_s):
            if not seen:
                (csv,) = [
                    p
                    for p in session_files(tmp_path, "P01", "luidolt2020", 1)
                    if p.suffix == ".csv"
                ]
                seen["header"] = csv.read_text()
                seen["sidecar"] = json.loads(csv.with_suffix(".json").read_text())
            return super().wait_keys(anchor_s)

    run_session(
        protocol,
        "P01",
        out=tmp_path,
        frontend=Watching(make_observer(protocol, "P01", seed=0, stimuli=None)),
        simulated=True,
    )
    assert seen["header"].startswith("study,participant,session,trial,block,onset_s")
    assert seen["sidecar"]["status"] == "running" and seen["sidecar"]["started"]


def test_a_completed_session_is_not_resumed(tmp_path):
    assert simulated(tmp_path).returncode == 0
    before = data_files(tmp_path)
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 2 and "is a completed session" in done.stderr
    assert data_files(tmp_path) == before


def _disk_of(size: int):
    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

    return limit


def test_a_disk_that_fills_during_a_session_stops_it_cleanly(tmp_path, stimulus_sets):
    """Each file may grow to 3000 bytes: the CSV fills after about a dozen Spencer trials."""
    done = glarelab(
        "run", "spencer1995", "--simulate", "--participant", "P01", "--out", tmp_path,
        "--stimuli", stimulus_sets / "spencer1995", preexec_fn=_disk_of(3000),
    )  # fmt: skip
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert "the session stopped after" in done.stderr and "every trial before it is on disk" in (
        done.stderr
    )
    (csv,) = [p for p in session_files(tmp_path, "P01", "spencer1995", 1) if p.suffix == ".csv"]
    text = csv.read_text()
    rows = text.splitlines()[1:]
    assert 5 <= len(rows) < 20 and text.endswith("\n")  # whole rows only
    sidecar = json.loads(csv.with_suffix(".json").read_text())
    assert sidecar["status"] == "aborted" and sidecar["trials"] == len(rows)
    assert sidecar["runs"][0]["ended_by"].startswith("could not write")
