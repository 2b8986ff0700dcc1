"""LiveView's loop without a screen: what it shows and for how long, on a clock of the test's."""

from __future__ import annotations

import errno
import json
import os
from types import SimpleNamespace

import numpy as np
import pytest

from glarelab.frontend.eyetracker import PupilCalibration
from glarelab.frontend.live import FRAME_COLUMNS, LiveView, _Record, run_live
from glarelab.glare.night.live import LiveNight
from glarelab.glare.rendering.display import CodeTable


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def getTime(self) -> float:  # PsychoPy's name
        return self.t


def _view(clock: Clock, first_render_s: float, render_s: float) -> LiveView:
    """A LiveView whose renderer takes ``first_render_s`` for its first frame (the bank being
    built) and ``render_s`` for each later one, and whose flips take no time."""
    view = object.__new__(LiveView)
    state = SimpleNamespace(
        gaze_x_px=5.0, gaze_y_px=5.0, pupil_mm=5.0, valid_gaze=True, valid_pupil=True,
        clamped=False,
    )  # fmt: skip
    rendered = []

    def frame(*, encode, **_):
        clock.t += render_s if rendered else first_render_s
        rendered.append(clock.t)
        image = np.zeros((4, 4), dtype=np.float32)
        return SimpleNamespace(
            image=image, codes=encode(image), render_ms=1.0, target_cd_m2=1.0,
            adaptation_cd_m2=1.0, new_entries=0,
        )  # fmt: skip

    view.filter = SimpleNamespace(update=lambda *a, **k: state)
    view.live = SimpleNamespace(frame=frame)
    view.top = 255
    view.encode = CodeTable(np.linspace(0.0, 1.0, 256))
    view.levels = (np.arange(256) / 255).astype(np.float32)
    view.stim = SimpleNamespace(image=None, draw=lambda: None)
    view.window = SimpleNamespace(flip=lambda: clock.t)
    view.origin_px = (0.0, 0.0)
    view.frames = view.dropped = 0
    view.render_ms = []
    return view


def test_the_free_viewing_lasts_its_seconds_from_the_first_frame_shown():
    # a first frame that takes 3 s to render (the bank built on a loaded machine) used to
    # take the whole 1 s viewing: one frame shown, for one frame's time
    clock = Clock()
    view = _view(clock, first_render_s=3.0, render_s=0.02)
    source = SimpleNamespace(time_s=lambda: clock.t, sample=lambda: (5.0, 5.0, 5.0))
    flips = view.run(
        source, clock=clock, refresh_hz=50.0, write_row=lambda *a: None, stop=lambda: False,
        duration_s=1.0,
    )  # fmt: skip
    assert flips[0] == 3.0
    assert flips[-1] - flips[0] >= 1.0 - 1e-9
    assert view.frames == 51  # 1 s of 20 ms frames after the first


SCENE = np.full((20, 30, 3), 0.02)


def test_run_live_refuses_an_earlier_runs_record_before_the_window_opens(tmp_path):
    # a second run into the same frames path replaced a 239-frame record with 61 frames
    frames = tmp_path / "P01_frames.tsv"
    frames.write_text("frame\n0\n")
    with pytest.raises(ValueError, match=r"P01_frames.tsv' already exists.*another name"):
        run_live(SCENE, pixel_deg=0.1, frames_path=frames, duration_s=0.1)
    assert frames.read_text() == "frame\n0\n"
    # an earlier run's json alone is refused too, and the claimed frames file given back
    other = tmp_path / "P02_frames.tsv"
    (tmp_path / "P02_live.json").write_text("{}")
    with pytest.raises(ValueError, match=r"P02_live.json' already exists"):
        run_live(SCENE, pixel_deg=0.1, frames_path=other, duration_s=0.1)
    assert not other.exists() and (tmp_path / "P02_live.json").read_text() == "{}"


def test_a_second_run_writing_the_same_record_at_once_is_refused(tmp_path):
    # two runs into one path at once both ended 0 with their rows interleaved
    frames = tmp_path / "P01_frames.tsv"
    first = _Record(frames, tmp_path / "P01_live.json")
    try:
        with pytest.raises(ValueError, match="a run writing it now"):
            _Record(frames, tmp_path / "P01_live.json")
        first.row(range(len(FRAME_COLUMNS)))
    finally:
        first.close()
    assert len(frames.read_text().splitlines()) == 2


def test_a_row_the_disk_cannot_take_is_cut_off_whole(tmp_path, monkeypatch):
    # a full disk left a half-written last row and a json without its end
    frames = tmp_path / "P01_frames.tsv"
    record = _Record(frames, tmp_path / "P01_live.json")
    record.facts({"tracker": "mouse"})
    assert json.loads(record.sidecar.read_text())["status"] == "cut short"
    record.row(range(14))
    write = os.write

    def full(fd, data):  # half the row goes, then the disk is full
        if fd == record.fd and len(data) > 10:
            write(fd, data[: len(data) // 2])
            raise OSError(errno.ENOSPC, "No space left on device")
        return write(fd, data)

    monkeypatch.setattr(os, "write", full)
    with pytest.raises(OSError):
        record.row(range(14))
    monkeypatch.setattr(os, "write", write)
    record.close()
    lines = frames.read_text().split("\n")
    assert lines[-1] == "" and len(lines) == 3  # the header and the one whole row
    assert lines[1].split("\t") == [str(v) for v in range(14)]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"refresh_hz": -60}, "refresh_hz must be a finite number > 0 Hz, got -60"),
        ({"refresh_hz": 0}, "refresh_hz must be a finite number > 0"),
        ({"duration_s": -1}, "duration_s must be"),
        ({"calibrate": True, "calibration_s": 0}, "calibration_s must be a finite number > 0"),
        ({"tracker": "nonsense"}, "tracker must be one of"),
        ({"tracker": ["mouse"]}, "tracker must be one of"),
        (
            {"calibration": PupilCalibration(white_raw=3.0, black_raw=5.5, range_mm=(1, 10))},
            r"calibration.range_mm = \(1, 10\) mm leaves the renderer's pupils, 2-8 mm",
        ),
    ],
)
def test_run_live_refuses_bad_arguments_before_the_window_opens(tmp_path, change, message):
    # refresh_hz=-60 flagged 364 of 365 frames dropped, 0 divided by zero after the window
    # opened, duration_s=-1 ran a frame, a 1-10 mm calibration died when the pupil passed 8 mm
    frames = tmp_path / "P01_frames.tsv"
    with pytest.raises(ValueError, match=message):
        run_live(SCENE, pixel_deg=0.1, frames_path=frames, **change)
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_run_live_names_a_missing_folder_not_the_tracker(tmp_path):
    frames = tmp_path / "nofolder" / "P01_frames.tsv"
    with pytest.raises(ValueError, match="nofolder' does not exist; make it first"):
        run_live(SCENE, pixel_deg=0.1, frames_path=frames, duration_s=0.1)


def test_a_live_view_refuses_a_calibration_beyond_its_bank():
    # a session's live scene would die midway when the pupil passed the bank's 8 mm
    live = LiveNight(SCENE, pixel_deg=0.1)
    wide = PupilCalibration(white_raw=3.0, black_raw=5.5, range_mm=(1.0, 10.0))
    with pytest.raises(ValueError, match=r"calibration.range_mm = \(1.0, 10.0\) mm leaves"):
        LiveView(None, live, lut=np.linspace(0.0, 1.0, 256), bits=8, calibration=wide)


@pytest.mark.parametrize(
    ("window_px", "fits"),
    [((640, 400), True), ((639, 400), False), ((640, 399), False), ((1280, 800), True)],
)
def test_a_live_view_knows_whether_the_scene_fits_its_window(window_px, fits):
    """A pilot's window smaller than the scene cut its edges off without a word: the
    session warns where the view does not fit (to the pixel, the scene centred)."""
    view = object.__new__(LiveView)
    view.live = type("Live", (), {"shape": (400, 640)})()
    view.window_px = window_px
    view.origin_px = (window_px[0] / 2 - 320, window_px[1] / 2 - 200)
    assert view.fits is fits
