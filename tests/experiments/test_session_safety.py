"""Every refusal before the first trial shows its message and leaves the data as it was, and
no failure of the disk or of the process loses a recorded trial."""

import json
import resource
import shutil
import signal
import subprocess
import sys
from datetime import datetime
from pathlib import Path

import pytest

from glarelab.cli import main
from glarelab.display.calibration import fit_calibration
from glarelab.display.checks import DisplayMismatch, ScreenFacts
from glarelab.experiments.data import SessionError, SessionFiles, session_files
from glarelab.experiments.session import SimulatedFrontend, make_observer, run_session
from glarelab.protocols import load_protocol
from tests.test_faults import small_disk  # noqa: F401 - a fixture: a 1 MiB tmpfs

from .xscreen import XScreen

ROOT = Path(__file__).parents[2]
PROTOCOLS = ROOT / "src" / "glarelab" / "protocols"
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


def test_a_resume_with_the_readings_refitted_by_another_method_is_refused(tmp_path, stimulus_sets):
    """Only the readings' digest was compared: the same readings fitted by another method (a
    curve that encodes every luminance otherwise) resumed the session without a word."""
    protocol = load_protocol("yoshida2008")
    readings = [(c, 0.5 + 432.5 * (c / 1023) ** 2.2) for c in range(0, 1024, 31)] + [(1023, 433.0)]
    fitted = fit_calibration(sorted(set(readings)), bit_depth=10, label="Barco, 433 cd/m²")
    refitted = fit_calibration(sorted(set(readings)), bit_depth=10, method="gog", label="Barco")
    relabelled = fit_calibration(sorted(set(readings)), bit_depth=10, label="Barco, relabelled")
    assert refitted.readings_sha256 == fitted.readings_sha256
    display = protocol["display"]
    facts = ScreenFacts(tuple(display["resolution_px"]), display["refresh_hz"], 10)
    out = tmp_path / "data"

    def run(calibration, **options):
        return run_session(
            protocol,
            "P01",
            out=out,
            frontend=_Screen(protocol, facts, stimulus_sets / "yoshida2008"),
            stimuli=stimulus_sets / "yoshida2008",
            calibration=calibration,
            allow_uncalibrated=True,
            **options,
        )

    with pytest.warns(UserWarning, match="not been verified"):
        first = run(fitted)
    assert first["calibration"]["curve_sha256"] == fitted.curve_sha256
    (sidecar,) = out.glob("*.json")  # as if it had ended with Escape
    sidecar.write_text(sidecar.read_text().replace('"status": "completed"', '"status": "aborted"'))
    before = data_files(out)
    with pytest.warns(UserWarning, match="not been verified"):
        with pytest.raises(SessionError, match=r"other inputs: the calibration \(curve sha256"):
            run(refitted, resume=True)
    assert data_files(out) == before
    with pytest.warns(UserWarning, match="not been verified"):
        resumed = run(relabelled, resume=True)  # the same curve: its label is no input
    assert resumed["calibration"]["curve_sha256"] == fitted.curve_sha256


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


def test_a_participants_session_is_held_across_output_folders_before_the_set_is_verified(
    tmp_path, stimulus_sets, monkeypatch, capsys
):
    """A second ``run`` of the same participant and session into another --out is refused at
    once: before its stimulus set is verified (seconds for a large set), and it leaves no
    --out folder behind."""
    from glarelab.experiments import session as sessions
    from glarelab.experiments.data import SessionLock

    verified = []
    monkeypatch.setattr(
        sessions, "prove_stimulus_set", lambda folder: verified.append(folder) or []
    )
    holder = SessionLock(tmp_path / "first", "P01", "yoshida2008", 1, across_folders=True)
    holder.acquire()  # the first run, into another folder
    try:
        status = main(
            ["run", "yoshida2008", "--participant", "P01", "--stimuli",
             str(stimulus_sets / "yoshida2008"), "--allow-uncalibrated",
             "--out", str(tmp_path / "second")]
        )  # fmt: skip
    finally:
        holder.release()
    err = capsys.readouterr().err
    assert status == 2, err
    assert "participant 'P01''s yoshida2008 session 1 is in use by another process" in err
    assert "whatever its output folder" in err
    assert verified == [] and not (tmp_path / "second").exists()
    assert simulated(tmp_path / "sim", "luidolt2020", "P01").returncode == 0  # simulations
    # lock their own folder: the power analyses run the same ids side by side


def test_a_refused_run_leaves_no_output_folder(tmp_path, stimulus_sets):
    out = tmp_path / "new"
    done = glarelab(  # a synthetic calibration, not accepted: refused before any file
        "run", "yoshida2008", "--participant", "P02", "--stimuli",
        stimulus_sets / "yoshida2008", "--out", out,
    )  # fmt: skip
    assert done.returncode == 2 and "the display calibration is" in done.stderr, done.stderr
    assert not out.exists()
    existing = tmp_path / "data"
    assert simulated(existing).returncode == 0
    again = simulated(existing)  # refused: the session has data; the folder is kept
    assert again.returncode == 2 and existing.is_dir()


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


def test_a_completed_session_cut_short_names_the_missing_trials_on_resume(tmp_path):
    """A completed session's CSV cut short was refused as 'a completed session: there is
    nothing to resume', hiding the trials missing, which the analysis names."""
    assert simulated(tmp_path).returncode == 0
    (csv,) = tmp_path.glob("P01_luidolt2020_s1_*.csv")
    recorded = json.loads(csv.with_suffix(".json").read_text())["trials"]
    assert recorded > 4
    csv.write_text("".join(csv.read_text().splitlines(keepends=True)[:4]))  # 3 trials
    before = data_files(tmp_path)
    done = simulated(tmp_path, "luidolt2020", "P01", "--resume")
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().endswith(
        f"{csv.name}: trials 4-{recorded} of the {recorded} the completed session recorded "
        "missing (rows deleted, or the file cut short?); a completed session is not resumed: "
        "put its rows back from a copy of the file, or keep it for the record and start a new "
        "session number"
    )
    assert data_files(tmp_path) == before


def test_a_disk_that_fills_during_a_session_stops_it_with_its_reason(
    small_disk,  # noqa: F811 - the fixture
    stimulus_sets,
    monkeypatch,
    capsys,
):
    """The disk is filled to its last byte after the fifth trial: a later row cannot be
    written (the CSV's last page of the tmpfs takes a few more), the session stops with status 4 (not 2, which says nothing was written), every
    trial before is on disk, and the sidecar is not left ``running``: it says why it ended."""
    import os

    from glarelab.experiments import session as sessions

    answer = sessions.SimulatedFrontend.wait_keys

    def fill_after_five(self, anchor_s):
        if len(list(small_disk.glob("*.csv"))) == 1:
            (csv,) = small_disk.glob("*.csv")
            if len(csv.read_text().splitlines()) == 6 and not (small_disk / "filler").exists():
                handle = os.open(small_disk / "filler", os.O_WRONLY | os.O_CREAT)
                try:
                    while True:
                        os.write(handle, b"\0" * 4096)
                except OSError:
                    pass
                finally:
                    os.close(handle)
        return answer(self, anchor_s)

    monkeypatch.setattr(sessions.SimulatedFrontend, "wait_keys", fill_after_five)
    status = main(
        ["run", "spencer1995", "--simulate", "--participant", "P01", "--out", str(small_disk),
         "--stimuli", str(stimulus_sets / "spencer1995")]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert status == 4 and "Traceback" not in err, err
    (csv,) = [p for p in session_files(small_disk, "P01", "spencer1995", 1) if p.suffix == ".csv"]
    text = csv.read_text()
    trials = len(text.splitlines()) - 1
    assert 5 <= trials < 60 and text.endswith("\n")  # whole rows only
    assert f"the session stopped after {trials} trials: could not write" in err
    assert "No space left on device" in err and f"{csv.stem}.json says why it ended" in err
    sidecar = json.loads(csv.with_suffix(".json").read_text())
    assert sidecar["status"] == "aborted" and sidecar["trials"] == trials and sidecar["ended"]
    assert sidecar["runs"][0]["ended_by"].startswith("could not write")
    assert "No space left on device" in sidecar["runs"][0]["ended_by"]
    assert not list(small_disk.glob(".*.reserve"))  # the room set aside is given back


def test_a_live_scene_given_a_calibration_checks_it_before_anything_is_written(tmp_path):
    # the live scene was encoded through --calibration while the sidecar said the calibration
    # was "not needed": another display's calibration (here a synthetic 50 cd/m² one, the
    # protocol's display is 200 cd/m²) went unchecked and unrecorded
    from glarelab.display.calibration import synthetic_calibration

    other = synthetic_calibration(max_cd_m2=50.0, black_cd_m2=0.05, bit_depth=8)
    with pytest.raises(ValueError, match="calibration"):
        run_session(
            load_protocol("luidolt2020-live"), "P01", out=tmp_path / "data", frontend=object(),
            calibration=other,
        )  # fmt: skip
    assert not (tmp_path / "data").exists()


def test_a_session_that_could_not_start_leaves_no_iohub_file(tmp_path):
    """ioHub's store and log of a live session whose tracker started but that ran no trial
    are removed with its other files: none is left to refuse the next attempt."""
    files = SessionFiles(
        load_protocol("luidolt2020"), "P01", 1, tmp_path, resume=False, started=datetime.now()
    )
    try:
        files.open()
        stem = files.csv_path.name.removesuffix(".csv")
        names = {f"{stem}_iohub.hdf5", f"{stem}_iohub.log"}
        for name in names:
            (tmp_path / name).write_text("ioHub")
        assert names < {p.name for p in session_files(tmp_path, "P01", "luidolt2020", 1)}
        files.discard()
        assert session_files(tmp_path, "P01", "luidolt2020", 1) == []
    finally:
        files.close()


def test_a_resumed_live_run_keeps_its_own_iohub_store(tmp_path, monkeypatch):
    """ioHub opens its hdf5 store anew: a resumed run (run 2) given the first run's store
    erased the first run's raw samples. Each run gets its own store, listed with the
    session's files."""
    pytest.importorskip("tables")
    from types import SimpleNamespace

    import glarelab.frontend.eyetracker as eyetracker
    from glarelab.experiments.data import tracker_store_name
    from glarelab.frontend.session import PsychoPyFrontend

    stem = "P01_luidolt2020-live_s1_2026-12-03_2100"
    stores = []

    class Launched(Exception):
        pass

    def launch(window, *, datastore, **_):
        stores.append(datastore)
        raise Launched

    monkeypatch.setattr(eyetracker, "IoHubEyeTracker", launch)
    frontend = SimpleNamespace(eyetracker=("mouse", {}), window=None, log=lambda line: None)
    for run in (1, 2, 3):
        with pytest.raises(Launched):
            PsychoPyFrontend._start_tracker(frontend, run, tmp_path / f"{stem}_frames.tsv")
    assert [p.name for p in stores] == [
        f"{stem}_iohub.hdf5", f"{stem}_iohub_run2.hdf5", f"{stem}_iohub_run3.hdf5"
    ]  # fmt: skip
    for store in stores:
        store.write_bytes(b"")
    listed = {p.name for p in session_files(tmp_path, "P01", "luidolt2020-live", 1)}
    assert {p.name for p in stores} <= listed
    for run in (0, -1, True, 1.0):
        with pytest.raises(ValueError, match="run must be a whole number >= 1"):
            tracker_store_name(stem, run)


def test_a_ctrl_c_while_a_completed_sessions_end_is_written_is_delivered_after_it(
    tmp_path, monkeypatch
):
    # the end was written with SIGINT ignored: the Ctrl-C was lost, and a simulated batch
    # went on to its next participant and ended with 0
    import json
    import os
    import signal

    import glarelab.experiments.session as session
    from glarelab.experiments.session import (
        SessionAborted,
        SimulatedFrontend,
        make_observer,
        run_session,
    )
    from glarelab.protocols import load_protocol

    calls = []
    real_now = session._now

    def now():
        calls.append(1)
        if len(calls) == 2:  # the run's end, inside its writing
            os.kill(os.getpid(), signal.SIGINT)
        return real_now()

    monkeypatch.setattr(session, "_now", now)
    protocol = load_protocol("luidolt2020")
    observer = make_observer(protocol, "P01", seed=1, stimuli=None)
    with pytest.raises(SessionAborted, match="SIGINT"):  # the command's exit 3
        run_session(
            protocol, "P01", out=tmp_path, frontend=SimulatedFrontend(observer), simulated=True
        )
    (sidecar,) = tmp_path.glob("P01_*.json")
    record = json.loads(sidecar.read_text())
    assert record["status"] == "completed" and record["runs"][-1]["status"] == "completed"
    assert len(calls) == 2


def test_a_ctrl_c_on_the_end_screen_ends_the_command_with_the_session_complete(tmp_path):
    # it was taken as closing the end screen: a simulated batch went on and ended with 0
    import json
    import os
    import signal

    from glarelab.experiments.session import (
        SessionAborted,
        SimulatedFrontend,
        make_observer,
        run_session,
    )
    from glarelab.protocols import load_protocol

    class CtrlCAtTheEnd(SimulatedFrontend):
        def show(self, screen):
            if screen.get("kind") == "end":
                os.kill(os.getpid(), signal.SIGINT)
            return super().show(screen)

    protocol = load_protocol("luidolt2020")
    observer = make_observer(protocol, "P01", seed=1, stimuli=None)
    with pytest.raises(SessionAborted, match="SIGINT"):
        run_session(
            protocol, "P01", out=tmp_path, frontend=CtrlCAtTheEnd(observer), simulated=True
        )
    (sidecar,) = tmp_path.glob("P01_*.json")
    assert json.loads(sidecar.read_text())["status"] == "completed"


@pytest.mark.parametrize(
    ("collecting", "error", "ended_by"),
    [
        (False, ValueError("ioHub started without the eye tracker 'eyelink'"), None),
        (True, ValueError("black_raw must exceed white_raw"), "error: ValueError: black_raw"),
        (True, OSError(28, "No space left on device", "x.log"), "could not write x.log: No sp"),
    ],
)
def test_a_run_that_fails_as_it_starts_is_not_left_running(tmp_path, collecting, error, ended_by):
    """A failure while the front-end started (a tracker that would not start, a pupil
    calibration refused, a full disk) left the sidecar saying 'running', which blocked the
    participant's session: nothing collected leaves no file, as any refusal before the start;
    what the tracker recorded is kept with its end."""
    protocol = load_protocol("luidolt2020")

    class Failing(SimulatedFrontend):
        def start(self, **settings):
            super().start(**settings)
            self.collecting = collecting
            raise error

    frontend = Failing(make_observer(protocol, "P01", seed=0, stimuli=None))
    with pytest.raises(type(error)):
        run_session(protocol, "P01", out=tmp_path, frontend=frontend, simulated=True)
    if not collecting:
        assert data_files(tmp_path) == {}
        return
    (sidecar,) = tmp_path.glob("*.json")
    recorded = json.loads(sidecar.read_text())
    assert recorded["status"] == "aborted" and recorded["runs"][-1]["status"] == "aborted"
    assert recorded["runs"][-1]["ended_by"].startswith(ended_by)


def test_a_signal_that_the_windows_cleanup_turns_into_another_error_still_stops_the_session(
    tmp_path,
):
    """SIGTERM during the pupil calibration raised the stop inside a GL call of a flip, and the
    calibration's last flip then failed with ctypes' ArgumentError: that error, not the stop,
    reached the command, which called it a bug (exit 70). The stop the signal asked for wins."""
    import ctypes
    import os
    import signal

    from glarelab.experiments.session import SessionAborted

    protocol = load_protocol("luidolt2020")

    class Interrupted(SimulatedFrontend):
        def start(self, **settings):
            super().start(**settings)
            self.collecting = True
            try:
                os.kill(os.getpid(), signal.SIGTERM)  # the handler raises the stop here
            except SessionAborted:
                raise ctypes.ArgumentError("argument 1: TypeError: wrong type") from None

    frontend = Interrupted(make_observer(protocol, "P01", seed=0, stimuli=None))
    with pytest.raises(SessionAborted, match="SIGTERM"):
        run_session(protocol, "P01", out=tmp_path, frontend=frontend, simulated=True)
    (sidecar,) = tmp_path.glob("*.json")
    run = json.loads(sidecar.read_text())["runs"][-1]
    assert (run["status"], run["ended_by"]) == ("aborted", "SIGTERM")


def test_a_stop_in_the_middle_of_a_sidecar_write_leaves_no_temporary_file(tmp_path):
    """SIGTERM to a simulated batch left a half-made ``….json.tmp`` in the data folder (2 of
    4 stops): the write removed its temporary file on a full disk only, not on a stop."""

    class Stopped:
        def __str__(self):
            raise KeyboardInterrupt  # the stop arrives while the sidecar is being written

    files = SessionFiles(
        load_protocol("luidolt2020"), "P01", 1, tmp_path, resume=False, started=datetime.now()
    )
    try:
        files.open()
        files.write_sidecar({"status": "running"})
        with pytest.raises(KeyboardInterrupt):
            files.write_sidecar({"status": "running", "stopped": Stopped()})
        assert not files.sidecar_path.with_suffix(".json.tmp").exists()
        assert json.loads(files.sidecar_path.read_text()) == {"status": "running"}
    finally:
        files.close()


def test_a_folder_removed_before_a_sidecar_write_gets_its_trials_back(tmp_path):
    """The session's folder removed between two trials: when the sidecar's write came first
    (before the next row's check), the session stopped with 'could not write' and its trials
    were gone with the folder."""
    out = tmp_path / "data"
    files = SessionFiles(
        load_protocol("luidolt2020"), "P01", 1, out, resume=False, started=datetime.now()
    )
    try:
        files.open()
        files.write_sidecar({"status": "running"})
        files.write_row(
            {"study": "luidolt2020", "participant": "P01", "session": 1, "trial": 1,
             "block": "questionnaire", "onset_s": 1.0, "time_s": 2.0, "dropped_frames": 0,
             "category": "Overall", "rating": 5}
        )  # fmt: skip
        shutil.rmtree(out.rename(tmp_path / "trash"))
        with pytest.raises(OSError, match=r"its 1 trials are written back to "):
            files.write_sidecar({"status": "running"})
        assert len(files.csv_path.read_text().splitlines()) == 2  # the header and the trial
    finally:
        files.close()
