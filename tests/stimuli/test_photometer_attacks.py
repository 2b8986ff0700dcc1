"""A photometer session under the faults of a lab: two measurements on one session file, a full
disk, a process killed between readings, a resume with another reading protocol."""

import errno
import json
import os

import numpy as np
import pytest

from glarelab.display.measure import MeasurementLock, MeasurementSession, SessionInUse
from glarelab.display.photometer import PatchProtocol, measure_patch
from tests.stimuli.fake_photometer import FakeMinolta
from tests.stimuli.test_photometer import fake, line, shown  # noqa: F401 - fixtures

pytest.importorskip("psychopy_minolta", reason="the photometer extra: pip install '.[photometer]'")


def test_a_second_measurement_of_the_same_session_is_refused(tmp_path, line, capsys):  # noqa: F811
    from glarelab.cli import main

    out = tmp_path / "d.json"
    device = FakeMinolta(lambda: 1.0, line_folder=line)
    try:
        with MeasurementLock(out):  # a measurement of this session runs
            status = main(["calibrate", "measure", "--out", str(out), "--photometer", "LS-100",
                           "--port", device.port])  # fmt: skip
            assert status == 2
            err = capsys.readouterr().err
            assert (
                f"{out.with_suffix('.session.json')} is being measured by another process (pid {os.getpid()}"
                in err
            )
            assert device.commands == []  # the second one never spoke to the photometer
            with pytest.raises(SessionInUse):
                MeasurementLock(out).__enter__()
        with MeasurementLock(out):  # free again once the first has ended
            pass
    finally:
        device.close()


def session(tmp_path, **kwargs):
    return MeasurementSession(
        bit_depth=8, out=tmp_path / "d.json", rng=np.random.default_rng(0), points=5, **kwargs
    )


def test_a_full_disk_keeps_the_last_saved_session_and_leaves_no_half_file(tmp_path, monkeypatch):
    measuring = session(tmp_path)
    measuring.keep_reading({"set": 0, "cd_m2": 1.0, "reply": "OK00, 1.000"})
    saved = measuring.session_path.read_text()

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(OSError, match="No space left"):
        measuring.keep_reading({"set": 0, "cd_m2": 1.01, "reply": "OK00, 1.010"})
    assert measuring.session_path.read_text() == saved
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.session.json"]


def test_a_killed_measurement_says_which_readings_no_patch_used(tmp_path):
    """Killed after the readings of a patch were kept but before the patch was: resumed, the
    patch is read again, and the file tells the orphaned readings from the patch's own."""
    readings = iter(np.linspace(1, 2, 200))
    measuring = session(tmp_path)
    measuring.instrument = {"model": "LS-100", "serial_number": None}

    def read():
        value = float(next(readings))
        return value, f"OK00, {value:.4g}"

    protocol = PatchProtocol(readings=2, settle_s=0)
    for _ in range(2):
        patch = measure_patch(read, protocol, keep=measuring.keep_reading)
        measuring.record(patch.luminance_cd_m2, readings=patch.readings, source="photometer")
    measure_patch(read, protocol, keep=measuring.keep_reading)  # SIGKILL before record()
    resumed = MeasurementSession.resume(measuring.session_path, measuring.out)
    assert [entry["readings_kept"] for entry in resumed.log] == [2, 4]
    assert len(resumed.raw) == 6
    (stop,) = resumed.interruptions
    assert stop["readings_kept"] == 6 and stop["code"] == measuring.current()["code"]
    assert "no fault recorded" in stop["message"] and "after 2 readings" in stop["message"]
    patch = measure_patch(read, protocol, keep=resumed.keep_reading)
    resumed.record(patch.luminance_cd_m2, readings=patch.readings, source="photometer")
    saved = json.loads(resumed.session_path.read_text())
    assert saved["log"][-1]["readings_kept"] == 8  # raw 6, 7: this patch's; 4, 5: no one's
    assert saved["interruptions"] == resumed.interruptions
    again = MeasurementSession.resume(resumed.session_path, resumed.out)
    assert again.interruptions == resumed.interruptions  # said once, not at every resume


def test_a_resume_with_another_reading_protocol_is_refused(tmp_path, line, capsys):  # noqa: F811
    from glarelab.cli import main

    out = tmp_path / "d.json"
    begun = session(tmp_path)
    begun.instrument = {"model": "LS-100", "serial_number": None, "port": "x"}
    begun.patch_protocol = {"readings": 3, "settle_s": 1.0, "spread_fraction": 0.01, "repeats": 2}
    begun.record(1.0, readings=[1.0, 1.0, 1.0], source="photometer")
    resume = ["calibrate", "measure", "--out", str(out), "--resume"]
    for extra, message in [
        (["--readings", "5"], "--readings 5: this session reads its patches with --readings 3"),
        (["--settle-s", "2"], "--settle-s 2: this session reads its patches with --settle-s 1"),
        (["--spread", "0.05"], "--spread 0.05: this session reads its patches with --spread"),
        (["--repeats", "0"], "--repeats 0: this session reads its patches with --repeats 2"),
    ]:
        assert main([*resume, *extra]) == 2
        assert message in capsys.readouterr().err
    assert json.loads(begun.session_path.read_text())["log"] == begun.log  # unchanged


def test_ctrl_c_ends_quietly_keeps_the_session_and_says_how_to_go_on(
    tmp_path,
    line,  # noqa: F811
    capsys,
    monkeypatch,
):

    import glarelab.frontend.measure
    from glarelab.cli import main

    def measuring_until_ctrl_c(session, *, meter, **kwargs):
        session.keep_reading({"set": 0, "cd_m2": 1.0, "reply": "OK00, 1.000"})
        raise KeyboardInterrupt

    monkeypatch.setattr(glarelab.frontend.measure, "run_measurement", measuring_until_ctrl_c)
    out = tmp_path / "d.json"
    device = FakeMinolta(lambda: 1.0, line_folder=line)
    try:
        status = main(["calibrate", "measure", "--out", str(out), "--photometer", "LS-100",
                       "--port", device.port, "--bit-depth", "8"])  # fmt: skip
    finally:
        device.close()
    assert status == 3
    err = capsys.readouterr().err
    assert "Traceback" not in err and "stopped by SIGINT" in err
    assert "the same command with --resume goes on from there" in err
    saved = json.loads(out.with_suffix(".session.json").read_text())
    assert len(saved["raw"]) == 1
    assert saved["interruptions"][-1]["message"] == "stopped by Ctrl-C (SIGINT)"
    resumed = MeasurementSession.resume(out.with_suffix(".session.json"), out)
    assert len(resumed.interruptions) == 1  # the stop is known: not "no fault recorded"


@pytest.mark.parametrize("model", ["LS-100", "PR-655"])
def test_a_reading_of_zero_is_no_reading(line, model):  # noqa: F811
    """An LS-100 reads down to 0.001 cd/m², and the PR-655 has no floor in the table: a 0
    from either is light too faint to measure, not a black of 0 cd/m² to fit."""
    from glarelab.display.photometer import OutOfRange, open_photometer
    from tests.stimuli.fake_photometer import FakePR655

    kind = FakePR655 if model == "PR-655" else FakeMinolta
    device = kind(lambda: 0.0, line_folder=line)
    try:
        meter = open_photometer(model, device.port)
        with pytest.raises(OutOfRange, match=rf"the {model} read 0 cd/m², under its range"):
            meter.read()
    finally:
        device.close()


def test_a_resume_with_another_session_setting_is_refused(tmp_path, capsys):
    from glarelab.cli import main

    begun = session(tmp_path, label="lab display")  # 8 bits, 5 points, random order
    begun.record(1.0)
    resume = ["calibrate", "measure", "--out", str(begun.out), "--resume"]
    for extra, message in [
        (["--bit-depth", "10"], "--bit-depth 10: this session was begun with --bit-depth 8"),
        (["--points", "33"], "--points 33: this session was begun with --points 5"),
        (["--order", "reversed"], "--order reversed: this session was begun with --order random"),
        (["--verify-points", "9"], "--verify-points 9: this session was begun with"),
        (["--tolerance", "0.05"], "--tolerance 0.05: this session was begun with --tolerance"),
        (["--label", "other"], "--label other: this session was begun with --label lab display"),
        (["--seed", "3"], "--seed 3: this session's order of codes is in its file"),
    ]:
        assert main([*resume, *extra]) == 2
        assert message in capsys.readouterr().err
    assert json.loads(begun.session_path.read_text())["log"] == begun.log  # unchanged


def test_a_pr655_measurement_that_failed_is_not_the_last_reading_again(line):  # noqa: F811
    """The plugin reads the luminance of the D3 report whatever the measurement's status: after
    a failed measurement that is the previous patch's luminance."""
    from glarelab.display.photometer import Garbled, OutOfRange, open_photometer
    from tests.stimuli.fake_photometer import FakePR655

    light = {"cd_m2": 120.0}
    device = FakePR655(lambda: light["cd_m2"], line_folder=line)
    try:
        meter = open_photometer("PR-655", device.port)
        assert meter.read()[0] == pytest.approx(120.0, rel=0.005)
        light["cd_m2"] = 0.5
        device.faults = ["-0001\r\n"]  # too little light: no measurement
        with pytest.raises(OutOfRange, match=r"PR-655 reports too little light \(status -1\)"):
            meter.read()
        device.faults = ["0010\r\n"]
        with pytest.raises(OutOfRange, match=r"too little light \(status 10\)"):
            meter.read()
        device.faults = ["-0008\r\n"]  # could not synchronise
        with pytest.raises(Garbled, match=r"reports status -8 for the measurement"):
            meter.read()
        device.faults = ["0018\r\n"]  # a reading (too weak to synchronise to): accepted
        meter.read()  # (the fake's status stands in for a measurement it did not make)
        assert meter.read()[0] == pytest.approx(0.5, rel=0.005)  # and a good one again
    finally:
        device.close()


def test_a_cable_pulled_while_a_command_is_sent_is_a_lost_photometer(fake):  # noqa: F811
    """Pulled while pyserial drains the line, the port fails with termios.error (EIO), which is
    not an OSError: it is the same lost photometer, not a crash."""
    import termios

    from glarelab.display.photometer import Disconnected, open_photometer

    meter = open_photometer("LS-100", fake.port)

    def pulled():
        raise termios.error(5, "Input/output error")

    meter.device.com.flush = pulled
    with pytest.raises(Disconnected, match=r"lost the LS-100 on /dev/pts/\d+ \(.*Input/output"):
        meter.read()
