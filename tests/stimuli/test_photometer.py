"""The photometers through PsychoPy's own plugin code, against a simulated LS-100 / CS-100A on
a pseudo-terminal (tests/stimuli/fake_photometer.py), faults included."""

import json
import os
import subprocess
import sys
import termios
import time

import numpy as np
import pytest

from glarelab.display.calibration import Calibration
from glarelab.display.measure import MeasurementSession
from glarelab.display.photometer import (
    Disconnected,
    Garbled,
    NoAnswer,
    OutOfRange,
    PatchProtocol,
    PhotometerError,
    measure_patch,
    open_photometer,
)
from tests.stimuli.fake_photometer import FakeMinolta, FakePR655
from tests.stimuli.pty_line import keeping_tcsetattr

pytest.importorskip("psychopy_minolta", reason="the photometer extra: pip install '.[photometer]'")

WHITE, BLACK, GAMMA = 150.0, 0.5, 2.2  # the known display


def display(code, top=255):
    return BLACK + (WHITE - BLACK) * (code / top) ** GAMMA


@pytest.fixture
def line(tmp_path, monkeypatch):
    """Pseudo-terminals take the serial line settings the plugin asks for (and tell the fake)."""
    folder = tmp_path / "lines"
    folder.mkdir()
    monkeypatch.setattr(termios, "tcsetattr", keeping_tcsetattr(folder))
    return folder


@pytest.fixture
def shown():
    return {"code": 255}


@pytest.fixture
def fake(line, shown):
    device = FakeMinolta(lambda: display(shown["code"]), line_folder=line, seed=1)
    yield device
    device.close()


@pytest.mark.parametrize("model", ["LS-100", "CS-100A"])
def test_the_plugin_reads_the_display(line, shown, model):
    device = FakeMinolta(lambda: display(shown["code"]), model=model, line_folder=line)
    try:
        meter = open_photometer(model, device.port, serial_number="40211007")
        for code in (0, 64, 255):
            shown["code"] = code
            value, reply = meter.read()
            assert reply == device.replies[-1]  # exactly as it came, line end included
            np.testing.assert_allclose(value, display(code), rtol=0.005)  # noise 0.1 %, 4 digits
        meter.close()
    finally:
        device.close()
    assert device.commands == ["MDS,04", "MES", "MES", "MES"]  # as the plugin speaks to it
    assert device.line_ok()  # it set the line to 4800 baud, 7E2
    assert meter.describe() == {
        "model": model,
        "port": device.port,
        "serial_number": "40211007",
        "plugin": "psychopy-minolta 0.0.2",
    }


def test_the_pr655_plugin_reads_the_display_and_its_serial_number(line, shown):
    device = FakePR655(lambda: display(shown["code"]), line_folder=line, serial_number="65551234")
    try:
        meter = open_photometer("PR-655", device.port)
        assert meter.serial_number == "65551234"
        shown["code"] = 128
        value, reply = meter.read()  # M0, then the plugin fetches D3, D1, D2, D5, D4
        np.testing.assert_allclose(value, display(128), rtol=0.005)
        assert reply.startswith("0000\r\n | 0000,0,") and "<103 lines>" in reply
        device.garble = True
        with pytest.raises(Garbled, match=r"the PR-655 on /dev/pts/.* which is not a reading"):
            meter.read()
        device.garble = False
        device.unplug_after = device.readings
        with pytest.raises(Disconnected, match="lost the PR-655"):
            meter.read()
    finally:
        device.close()
    assert device.commands[:9] == ["PHOTO", "D111", "D110", "M0", "D3", "D1", "D2", "D5", "D4"]
    assert device.line_ok()  # 9600 baud, 8N1


def test_faults_have_their_own_message(fake, shown):
    meter = open_photometer("LS-100", fake.port)
    fake.garble = True
    with pytest.raises(Garbled, match=r"answered '\\x1b7#;~\?\\r\\n', which is not a reading"):
        meter.read()
    fake.garble = False
    fake.ceiling_cd_m2 = 100.0
    with pytest.raises(OutOfRange, match=r"reports over range \(ER10"):
        meter.read()
    fake.ceiling_cd_m2 = 1e6
    device = FakeMinolta(lambda: 0.0004, line_folder=fake.line_file.parent)  # an OLED's black
    try:
        with pytest.raises(OutOfRange, match=r"read 0.000\d+ cd/m², under its range \(0.001"):
            open_photometer("LS-100", device.port).read()
    finally:
        device.close()
    fake.unplug_after = fake.readings
    with pytest.raises(Disconnected, match=r"lost the LS-100 on /dev/pts/.*plug the cable back"):
        meter.read()
    with pytest.raises(Disconnected, match="cannot open the serial port '/dev/nonexistent'"):
        open_photometer("LS-100", "/dev/nonexistent")
    with pytest.raises(ValueError, match="photometer must be one of LS-100, LS-110, CS-100A"):
        open_photometer("LS-1000", fake.port)


def test_a_reply_that_is_not_text_is_kept_and_named_a_line_settings_fault(fake, line):
    from glarelab.display.photometer import LineSettings
    from tests.stimuli.fake_photometer import WRONG_LINE

    meter = open_photometer("LS-100", fake.port)
    fake.faults = [WRONG_LINE]  # the adapter was switched to another baud rate meanwhile
    with pytest.raises(LineSettings) as fault:
        meter.read()
    message = str(fault.value)
    assert message.startswith(
        f"the LS-100 on {fake.port} answered bytes that are not text "
        "(b'\\xf0\\x8c\\xe6\\x9e\\xfc\\xe0\\x80\\r\\n'): the serial line's settings"
    )
    assert "4800 baud, 7 data bits, even parity, 2 stop bits" in message
    assert meter.last_reply == "not text: b'\\xf0\\x8c\\xe6\\x9e\\xfc\\xe0\\x80\\r\\n'"
    assert "does not answer" not in message
    assert isinstance(fault.value, Garbled)  # a garbled reply, of its own kind
    assert meter.read()[0] > 0  # set alike again, it reads

    other = FakeMinolta(lambda: 10.0, line_folder=line)
    other.LINE = {"baud": 9600, "line": "8N1"}  # an instrument set to another line
    try:
        with pytest.raises(LineSettings, match=r"answered bytes that are not text \(b'\\xf0"):
            open_photometer("LS-100", other.port)
    finally:
        other.close()


def test_a_photometer_that_does_not_answer(fake):
    meter = open_photometer("LS-100", fake.port)
    fake.mute = True
    with pytest.raises(NoAnswer, match=r"the LS-100 on /dev/pts/\d+ does not answer.*holding F"):
        meter.read()  # the plugin waits 5 s for a reply
    fake.garble = True
    fake.mute = False
    with pytest.raises(Garbled, match=r"something on /dev/pts/.* answers .*not as a LS-100 does"):
        open_photometer("LS-100", fake.port)


def test_a_patch_is_read_after_it_settles_and_again_when_its_readings_disagree(line, shown):
    device = FakeMinolta(lambda: display(shown["code"]), line_folder=line, settle_tau_s=0.15)
    try:
        meter = open_photometer("LS-100", device.port)
        shown["code"] = 0  # a step from white to black: the LCD takes its time
        time.sleep(0.05)
        hasty = measure_patch(meter.read, PatchProtocol(readings=3, settle_s=0, repeats=3))
        shown["code"] = 255
        time.sleep(0.05)
        patient = measure_patch(meter.read, PatchProtocol(readings=2, settle_s=1.2))
    finally:
        device.close()
    assert hasty.sets > 1 and len(hasty.readings) == 3 * hasty.sets
    assert hasty.readings[0] > 2 * hasty.readings[-1]  # still falling
    assert patient.sets == 1
    np.testing.assert_allclose(patient.luminance_cd_m2, WHITE, rtol=0.005)


def measure(session, meter, shown, protocol):
    """The measurement loop of the front-end, without the window."""
    while session.phase != "done":
        shown["code"] = session.current()["code"]
        time.sleep(0.02)  # the fake sees the new patch
        patch = measure_patch(meter.read, protocol, keep=session.keep_reading, wait=time.sleep)
        session.record(patch.luminance_cd_m2, readings=patch.readings, source="photometer")


def test_an_unplugged_photometer_loses_no_reading_and_the_session_resumes(tmp_path, line, shown):
    protocol = PatchProtocol(readings=2, settle_s=0.0)
    out = tmp_path / "display.json"
    session = MeasurementSession(
        bit_depth=8, out=out, rng=np.random.default_rng(3), points=5, verify_points=3
    )
    first = FakeMinolta(lambda: display(shown["code"]), line_folder=line, seed=2)
    first.unplug_after = 5  # in the middle of the third patch
    meter = open_photometer("LS-100", first.port, serial_number="A1")
    session.instrument = meter.describe()
    with pytest.raises(Disconnected) as fault:
        measure(session, meter, shown, protocol)
    session.interrupted(str(fault.value))
    first.close()
    saved = json.loads(session.session_path.read_text())
    replied = [r for r in first.replies if r.startswith("OK00, ")]  # as sent
    assert [r["reply"] for r in saved["raw"]] == replied  # every reading, the last one's too
    assert len(saved["raw"]) == 5 and len(saved["log"]) == 2
    assert saved["interruptions"][0]["message"].startswith("lost the LS-100")

    resumed = MeasurementSession.resume(session.session_path, out)
    assert resumed.current()["code"] == session.current()["code"]  # where it stopped
    second = FakeMinolta(lambda: display(shown["code"]), line_folder=line, seed=3)
    try:
        measure(resumed, open_photometer("LS-100", second.port), shown, protocol)
    finally:
        second.close()
    done = json.loads(session.session_path.read_text())
    assert done["raw"][:5] == saved["raw"]
    assert len(done["raw"]) == 5 + 2 * (5 - 2 + 1 + 3)  # the rest of the patches, 2 readings each
    calibration = Calibration.load(out)
    assert calibration.status == "passed"
    codes = np.arange(256)
    np.testing.assert_allclose(calibration.decode(codes), display(codes), rtol=0.01, atol=0.005)


def test_drift_shows_when_the_first_patch_is_read_again(tmp_path, line, shown):
    device = FakeMinolta(lambda: display(shown["code"]), line_folder=line)
    device.drift_per_reading = 0.004  # the photometer warms up
    session = MeasurementSession(
        bit_depth=8, out=tmp_path / "d.json", rng=np.random.default_rng(0), points=5
    )
    try:
        meter = open_photometer("LS-100", device.port)
        while session.phase == "measure":
            shown["code"] = session.current()["code"]
            time.sleep(0.02)
            patch = measure_patch(meter.read, PatchProtocol(readings=1, settle_s=0))
            session.record(patch.luminance_cd_m2, readings=patch.readings, source="photometer")
    finally:
        device.close()
    assert any(flag.startswith("drift: code") for flag in session.flags), session.flags


def test_every_fault_reaches_the_caller_as_a_photometer_error():
    for fault in (NoAnswer, Garbled, OutOfRange, Disconnected):
        assert issubclass(fault, PhotometerError)
    assert issubclass(PhotometerError, RuntimeError)


# --- a full measurement in a PsychoPy window under Xvfb, the fake looking at the screen -----------


def glarelab_on(x, line, *args):
    """``glarelab ARGS`` on the X screen, its serial lines set up as the fake expects."""
    log = open(x.tmp_path / f"glarelab-{time.monotonic_ns()}.stderr", "w")
    process = subprocess.Popen(
        [sys.executable, "-m", "tests.stimuli.pty_line", str(line), "-m", "glarelab", *args],
        env={**x.env, "PYTHONPATH": os.getcwd()},
        stdout=subprocess.DEVNULL,
        stderr=log,
    )
    return process, log


class ScreenPixel:
    """The drive code the X screen shows at its centre: what the photometer looks at.

    One connection for the whole test (libX11 through ctypes), shared by the fake's threads.
    """

    def __init__(self, display: str, at=(960, 540)):
        import ctypes
        import ctypes.util
        import threading

        self.x11 = ctypes.CDLL(ctypes.util.find_library("X11"))
        self.x11.XOpenDisplay.restype = ctypes.c_void_p
        self.x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
        self.x11.XDefaultRootWindow.restype = ctypes.c_ulong
        self.x11.XDefaultRootWindow.argtypes = [ctypes.c_void_p]
        self.x11.XGetImage.restype = ctypes.c_void_p
        self.x11.XGetImage.argtypes = [ctypes.c_void_p, ctypes.c_ulong, ctypes.c_int,
                                       ctypes.c_int, ctypes.c_uint, ctypes.c_uint,
                                       ctypes.c_ulong, ctypes.c_int]  # fmt: skip
        self.x11.XGetPixel.restype = ctypes.c_ulong
        self.x11.XGetPixel.argtypes = [ctypes.c_void_p, ctypes.c_int, ctypes.c_int]
        self.x11.XDestroyImage.argtypes = [ctypes.c_void_p]
        self.x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
        self.connection = self.x11.XOpenDisplay(display.encode())
        assert self.connection, f"cannot connect to the X screen {display}"
        self.root = self.x11.XDefaultRootWindow(self.connection)
        self.at = at
        self.lock = threading.Lock()

    def __call__(self) -> int:
        with self.lock:
            image = self.x11.XGetImage(self.connection, self.root, *self.at, 1, 1, 0xFFFFFF, 2)
            pixel = self.x11.XGetPixel(image, 0, 0)
            self.x11.XDestroyImage(image)
        return int((pixel >> 16) & 0xFF)  # red, as the patch is grey

    def close(self) -> None:
        with self.lock:
            self.x11.XCloseDisplay(self.connection)


def wait_for_faults(session_path, count, process, x, log, timeout=120):
    """The session's faults, once there are ``count`` of them."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        if session_path.exists():
            faults = json.loads(session_path.read_text())["interruptions"]
            if len(faults) >= count:
                return faults
        assert process.poll() is None, (x.tmp_path / log.name).read_text()[-3000:]
        time.sleep(0.1)
    raise AssertionError(f"no fault {count} after {timeout} s")


def test_a_measurement_in_a_window_survives_a_pulled_cable_and_gives_the_known_display(
    tmp_path, line
):
    """``calibrate measure --photometer LS-100`` in a full-screen PsychoPy window, the fake
    photometer looking at the screen's centre. The first reading is garbage (R reads again), the
    cable is pulled in the third patch (Escape; plugged in again, --resume), the first reading
    after resuming is over range (the operator types the reading)."""
    from tests.experiments.xscreen import XScreen

    x = XScreen(tmp_path)
    out = tmp_path / "display.json"
    session_path = out.with_suffix(".session.json")
    pixel = ScreenPixel(x.display)
    common = ["--out", out, "--bit-depth", "8", "--points", "9", "--verify-points", "3"]
    devices = []
    try:
        first = FakeMinolta(lambda: display(pixel()), line_folder=line, seed=5)
        devices.append(first)
        first.faults = ["?\x7f\x13\r\n"]  # garbage for the first reading: R reads again
        first.unplug_after = 5  # then the cable comes out in the third patch
        process, log = glarelab_on(
            x, line, "calibrate", "measure", *common, "--photometer", "LS-100",
            "--port", first.port, "--readings", "2", "--settle-s", "0.2",
            "--photometer-serial", "40211007",
        )  # fmt: skip
        faults = wait_for_faults(session_path, 1, process, x, log)
        assert "which is not a reading" in faults[0]["message"]
        x.focus_window()
        x.key("r")
        faults = wait_for_faults(session_path, 2, process, x, log)
        assert faults[1]["message"].startswith("lost the LS-100")
        stopped = json.loads(session_path.read_text())
        time.sleep(0.5)
        shot = x.screenshot()
        assert (shot[540, 960] == shot[100, 1800]).all()  # the patch stays on the screen
        assert (shot[900:1080, :900] != shot[540, 960]).any(axis=-1).sum() > 500  # the message
        x.key("Escape")
        assert process.wait(timeout=60) == 1
        stderr = (x.tmp_path / log.name).read_text()
        assert "photometer fault at measure code" in stderr
        assert "the same command with --resume goes on from there" in stderr
        first.close()
        replied = [r for r in first.replies if r.startswith("OK00, ")]  # as sent
        assert [r["reply"] for r in stopped["raw"]] == replied and len(replied) == 5

        second = FakeMinolta(lambda: display(pixel()), line_folder=line, seed=6)
        devices.append(second)
        second.faults = ["ER10\r\n"]  # over range: the operator types the reading instead
        process, log = glarelab_on(
            x, line, "calibrate", "measure", *common, "--photometer", "LS-100",
            "--port", second.port, "--resume",
        )  # fmt: skip
        faults = wait_for_faults(session_path, 3, process, x, log)
        assert "reports over range (ER10" in faults[2]["message"]
        typed = f"{display(pixel()):.4g}"
        x.focus_window()
        x.key(*["period" if c == "." else c for c in typed], "Return")
        assert process.wait(timeout=240) == 0, (x.tmp_path / log.name).read_text()[-3000:]
    finally:
        for device in devices:
            device.close()
        pixel.close()
        x.close()
    done = json.loads(session_path.read_text())
    assert done["raw"][:5] == stopped["raw"]  # nothing lost, nothing changed
    assert len(done["raw"]) == 5 + 2 * (9 - 2 + 1 + 3 - 1)  # the rest, 2 readings each, but…
    sources = [entry["source"] for entry in done["log"]]
    assert sources.count("typed") == 1 and sources.count("photometer") == 9 + 1 + 3 - 1
    assert done["log"][2]["source"] == "typed" and done["log"][2]["cd_m2"] == float(typed)
    assert done["instrument"]["serial_number"] == "40211007"
    assert done["instrument"]["model"] == "LS-100"
    calibration = Calibration.load(out)
    assert calibration.status == "passed"
    codes = np.arange(256)
    np.testing.assert_allclose(calibration.decode(codes), display(codes), rtol=0.01, atol=0.005)


def test_check_display_reads_black_white_and_the_calibration(tmp_path, line):
    from glarelab.display.calibration import fit_calibration
    from tests.experiments.xscreen import XScreen

    codes = np.unique(np.round(np.linspace(0, 255, 33)).astype(int))
    calibration = tmp_path / "display.json"
    fit_calibration(list(zip(codes, display(codes), strict=True)), bit_depth=8).save(calibration)
    out = tmp_path / "check.json"
    x = XScreen(tmp_path)
    pixel = ScreenPixel(x.display)
    device = FakeMinolta(lambda: display(pixel()), line_folder=line, seed=7)
    try:
        process, log = glarelab_on(
            x, line, "check-display", "spencer1995", "--calibration", calibration, "--out", out,
            "--frames", "30", "--photometer", "LS-100", "--port", device.port,
            "--readings", "2", "--settle-s", "0.1",
            "--accept-mismatch", "calibration",  # a 150 cd/m² display, Spencer's is 50
        )  # fmt: skip
        status = process.wait(timeout=240)
        assert status == 1, (x.tmp_path / log.name).read_text()[-3000:]  # Xvfb's resolution
    finally:
        device.close()
        pixel.close()
        x.close()
    result = json.loads(out.read_text())
    found = result["photometer"]
    assert found["fault"] is None and found["instrument"]["model"] == "LS-100"
    # black, white and five codes across the range; Spencer's lamp peak of 75 cd/m² is above
    # its display's 50 (a glare source's luminance, never shown as it is), so it is no target
    assert len(found["readings"]) == 2 * 7
    assert {p["code"] for p in found["patches"]} >= {0, 255}
    np.testing.assert_allclose(found["white_cd_m2"], WHITE, rtol=0.005)
    np.testing.assert_allclose(found["black_cd_m2"], BLACK, rtol=0.005)
    assert found["max_relative_error"] < 0.01
    checks = {check["name"]: check["passed"] for check in result["checks"]}
    assert checks["white luminance"] and checks["luminance against the calibration"]


def test_the_command_refuses_what_it_cannot_do(tmp_path, line, capsys):
    from glarelab.cli import main

    out = str(tmp_path / "d.json")
    cases = [
        (["--port", "/dev/ttyUSB0"], "--port needs --photometer MODEL"),
        (["--photometer", "LS-100"], "--photometer LS-100 needs --port (e.g. /dev/ttyUSB0"),
        (["--photometer", "LS-100", "--port", "/dev/nonexistent"], "cannot open the serial port"),
        (["--resume"], "no measurement session at"),
        (["--simulate", "100", "0.1", "2.2", "--photometer", "LS-100", "--port", "x"], "not both"),
    ]
    for extra, message in cases:
        assert main(["calibrate", "measure", "--out", out, *extra]) == 2
        assert message in capsys.readouterr().err
    device = FakeMinolta(lambda: 1.0, line_folder=line)
    device.garble = True  # a photometer fault is a message, not a bug (exit 2, not 70)
    try:
        assert main(["calibrate", "measure", "--out", out, "--photometer", "LS-100",
                     "--port", device.port]) == 2  # fmt: skip
    finally:
        device.close()
    assert f"something on {device.port} answers" in capsys.readouterr().err
    session = MeasurementSession(
        bit_depth=8, out=tmp_path / "d.json", rng=np.random.default_rng(0), points=5
    )
    session.record(1.0)
    assert main(["calibrate", "measure", "--out", out, "--bit-depth", "8"]) == 2
    assert "stopped before its end (1 patches done); --resume goes on" in capsys.readouterr().err


def test_a_session_is_finished_with_the_instrument_that_began_it(tmp_path, fake, capsys):
    from glarelab.cli import main

    out = tmp_path / "d.json"
    session = MeasurementSession(bit_depth=8, out=out, rng=np.random.default_rng(0), points=5)
    session.instrument = {"model": "LS-100", "serial_number": "A1", "port": fake.port}
    session.record(1.0, readings=[1.0], source="photometer")
    resume = ["calibrate", "measure", "--out", str(out), "--port", fake.port, "--resume"]
    assert main([*resume, "--photometer", "CS-100A"]) == 2
    assert "this session was measured with a LS-100; finish it with" in capsys.readouterr().err
    assert main([*resume, "--photometer", "LS-100", "--photometer-serial", "B2"]) == 2
    err = capsys.readouterr().err
    assert "is serial number B2, this session was measured with A1" in err
    assert json.loads(session.session_path.read_text())["log"] == session.log  # unchanged


def _srgb(code, top=255, white=WHITE, black=BLACK):
    v = np.asarray(code, dtype=float) / top
    return black + (white - black) * np.where(
        v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4
    )


def _toe(code, top=255, white=WHITE, black=BLACK):  # power 2.4, linear below 10 %
    v = np.asarray(code, dtype=float) / top
    return black + (white - black) * np.where(v < 0.1, v * 0.1**1.4, v**2.4)


@pytest.mark.parametrize("curve", [_srgb, _toe], ids=["sRGB", "power 2.4 with a linear toe"])
def test_a_photometer_reading_the_screen_calibrates_curves_with_a_linear_toe(
    tmp_path, line, curve
):
    """``calibrate measure`` in a window, the simulated LS-100 reading the screen's centre
    through the display's curve with 0.3 % noise: the calibration passes, the luminances the
    studies name verified too, and its curve is the display's within the noise, with codes
    added where the curve bends. (A gamma display read from the screen: the pulled-cable test
    above; every curve at 8 and 10 bits without a window: tests/stimuli/test_measure.py.)"""
    from tests.experiments.xscreen import XScreen

    x = XScreen(tmp_path)
    out = tmp_path / "display.json"
    pixel = ScreenPixel(x.display)
    device = FakeMinolta(lambda: float(curve(pixel())), line_folder=line, seed=3)
    device.noise_fraction = 0.003
    try:
        process, log = glarelab_on(
            x, line, "calibrate", "measure", "--out", out, "--bit-depth", "8", "--points", "17",
            "--photometer", "LS-100", "--port", device.port, "--readings", "2",
            "--settle-s", "0.05", "--photometer-serial", "40211007",
            "--protocol", "spencer1995", "night2026",
        )  # fmt: skip
        status = process.wait(timeout=400)
    finally:
        device.close()
        pixel.close()
        x.close()
    stderr = (x.tmp_path / log.name).read_text()
    assert status == 0, stderr[-3000:]
    calibration = Calibration.load(out)
    assert calibration.status == "passed" and calibration.method == "pchip-log"
    targets = [m["target_cd_m2"] for m in calibration.verification["measurements"]]
    assert 100.0 in targets  # the night's lit room; Spencer's lamp peak of 75 cd/m² is above
    assert 75.0 not in targets  # its display's 50, a glare source's, never shown as it is
    codes = np.arange(256)
    error = np.abs(calibration.decode(codes) - curve(codes)) / curve(codes)
    first = calibration.readings[1][0]
    assert error[first:].max() < 0.012, (error.max(), error.argmax())
    session = json.loads(out.with_suffix(".session.json").read_text())
    added = [e["code"] for e in session["log"] if e.get("purpose") == "refine"]
    assert added and min(added) < 0.15 * 255  # codes added where the curve bends, the toe
