"""The tracker's faults are held, clamped, smoothed and counted; Luidolt's pupil range."""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

import numpy as np
import pytest

from glarelab.frontend.eyetracker import (
    MOUSE_GAZE_SETTINGS,
    PUPIL_FILTER_S,
    GazeFilter,
    IoHubEyeTracker,
    PupilCalibration,
    calibrate_pupil,
    datastore_settings,
    tracker_config,
)


def test_pupil_calibration_maps_white_to_2_and_black_to_8_mm():
    # Luidolt 2020 §5.2.1 ii: white-screen mean the minimum, black-screen mean the maximum
    c = PupilCalibration.from_samples([3.0, 0.0, 3.0, np.nan], [7.0, 7.0], unit="mm")
    assert (c.white_raw, c.black_raw) == (3.0, 7.0)  # the blink (0) and the lost (NaN) dropped
    np.testing.assert_allclose([c.to_mm(3.0), c.to_mm(5.0), c.to_mm(7.0)], [2.0, 5.0, 8.0])
    assert (c.to_mm(1.0), c.to_mm(20.0)) == (2.0, 8.0)  # clamped to Luidolt's range
    assert c.as_dict()["range_mm"] == [2.0, 8.0]


def test_a_tracker_without_pupil_range_is_refused():
    # MouseGaze reports 5 mm on both screens: no range to map (and the way out named, where
    # it said only that black_raw must exceed white_raw)
    with pytest.raises(ValueError, match=r"5 mm on the white screen and on the black.*"
                       r"MouseGaze.*--eyetracker mouse"):  # fmt: skip
        PupilCalibration.from_samples([5.0, 5.0], [5.0, 5.0])
    with pytest.raises(ValueError, match="black_raw must exceed white_raw"):
        PupilCalibration.from_samples([6.0, 6.0], [5.0, 5.0])


def test_blinks_and_lost_samples_hold_the_last_state_and_are_counted():
    f = GazeFilter((200, 100), pupil_filter_s=0.0)
    f.update(0.0, 50.0, 40.0, 4.0)
    for t, sample in ((0.01, (None, None, 0.0)), (0.02, (None, None, None)),
                      (0.03, (math.nan, 1.0, math.nan))):  # fmt: skip
        state = f.update(t, *sample)
        assert (state.gaze_x_px, state.gaze_y_px, state.pupil_mm) == (50.0, 40.0, 4.0)
        assert not (state.valid_gaze or state.valid_pupil)
    # one blink of three samples (it was counted as three)
    assert f.counts() == {"samples": 4, "lost": 3, "blinks": 1, "off_screen": 0}


def test_a_blink_counts_once_and_the_start_up_and_a_disconnect_not_at_all():
    # two MouseGaze blinks were logged as 0 blinks; the start-up frame and a disconnect's
    # samples counted as blinks
    f = GazeFilter((200, 100))
    f.update(0.0, None, None, None, blink=False)  # no sample yet
    f.update(0.01, None, None, None)  # still none: the tracker has not seen the eye
    times = iter(np.arange(0.02, 1.0, 0.01))
    for blinking in (False, True, True, False, True, False):
        pupil = None if blinking else 5.0
        f.update(next(times), None if blinking else 5.0, 5.0, pupil, blink=blinking)
    for _ in range(3):  # a disconnect: samples lost, the eye not reported closed
        f.update(next(times), None, None, None, blink=False)
    assert (f.blinks, f.lost) == (2, 8)  # lost: 2 at the start, 3 blinking, 3 disconnected


def test_a_non_finite_time_is_refused_and_leaves_the_state():
    # time_s = NaN made the pupil NaN for every later sample
    f = GazeFilter((200, 100))
    f.update(0.0, 5.0, 5.0, 4.0)
    for bad in (math.nan, math.inf, "1"):
        with pytest.raises(ValueError, match="time_s must be a finite number"):
            f.update(bad, 5.0, 5.0, 6.0)
    state = f.update(0.1, 5.0, 5.0, 6.0)
    assert math.isfinite(state.pupil_mm) and f.samples == 2


def _tracker(event, window=(640, 400)):
    """An IoHubEyeTracker whose device gives one binocular sample of ioHub's fields."""
    from psychopy.iohub.devices.eyetracker.eye_events import (
        BinocularEyeSampleEvent,
        MonocularEyeSampleEvent,
    )

    names = list(BinocularEyeSampleEvent.CLASS_ATTRIBUTE_NAMES)
    tracker = object.__new__(IoHubEyeTracker)
    tracker.io = SimpleNamespace()
    tracker.device_handle = SimpleNamespace(getLastSample=lambda: [event.get(n, 0) for n in names])
    tracker.window = SimpleNamespace(size=window)
    tracker.disconnects = 0
    tracker._names = {"mono": list(MonocularEyeSampleEvent.CLASS_ATTRIBUTE_NAMES), "bino": names}
    return tracker


def test_a_binocular_tracker_that_loses_one_eye_gives_the_other_eyes_pupil():
    # a lost eye (ioHub: status 2 the right, 20 the left; its fields 0) halved the pupil
    both = {
        "left_gaze_x": 10.0, "right_gaze_x": 12.0, "left_gaze_y": 5.0, "right_gaze_y": 7.0,
        "left_pupil_measure1": 6.0, "right_pupil_measure1": 5.0, "status": 0,
    }  # fmt: skip
    assert _tracker(both).sample() == (331.0, 194.0, 5.5)
    right_lost = {**both, "right_gaze_x": 0, "right_gaze_y": 0, "right_pupil_measure1": 0}
    tracker = _tracker({**right_lost, "status": 2})
    assert tracker.sample() == (330.0, 195.0, 6.0) and not tracker.blinking
    left_lost = {**both, "left_gaze_x": 0, "left_gaze_y": 0, "left_pupil_measure1": 0}
    assert _tracker({**left_lost, "status": 20}).sample() == (332.0, 193.0, 5.0)
    tracker = _tracker({**both, "status": 22})  # both eyes missing: a blink
    assert tracker.sample() == (None, None, None) and tracker.blinking


def test_the_mouse_settings_are_a_copy_of_their_own():
    # editing the returned settings changed MOUSE_GAZE_SETTINGS for every later session
    _, settings = tracker_config("mouse")
    settings["runtime_settings"]["sampling_rate"] = 1
    settings["controls"]["blink"].clear()
    assert MOUSE_GAZE_SETTINGS["runtime_settings"]["sampling_rate"] == 200
    assert tracker_config("mouse")[1]["controls"]["blink"] == ["LEFT_BUTTON", "RIGHT_BUTTON"]


def test_a_tracker_file_whose_settings_are_a_list_says_so(tmp_path):
    # it said "must configure exactly one ioHub eye tracker ...; found 1"
    path = tmp_path / "tracker.yaml"
    path.write_text("eyetracker.hw.mouse.EyeTracker:\n  - sampling_rate: 100\n")
    with pytest.raises(ValueError, match=r"settings of eyetracker.hw.mouse.EyeTracker must be a"):
        tracker_config(str(path))


def test_a_pupil_calibration_names_a_field_that_is_not_a_number():
    # PupilCalibration(white_raw="3") gave a bare "TypeError: must be real number, not str"
    with pytest.raises(ValueError, match=r"white_raw must be a finite number.*'3'"):
        PupilCalibration(white_raw="3", black_raw=5.0)
    with pytest.raises(ValueError, match="range_mm must be"):
        PupilCalibration(white_raw=3.0, black_raw=5.0, range_mm="2-8")


def test_gaze_off_the_window_is_clamped_and_counted():
    f = GazeFilter((200, 100))
    state = f.update(0.0, -5.0, 300.0, 5.0)
    assert (state.gaze_x_px, state.gaze_y_px, state.clamped) == (0.0, 99.0, True)
    assert f.update(0.01, 10.0, 10.0, 5.0).clamped is False
    assert f.off_screen == 1


def test_the_pupil_follows_a_step_with_its_time_constant():
    f = GazeFilter((10, 10))
    f.update(0.0, 1.0, 1.0, 4.0)
    state = f.update(PUPIL_FILTER_S, 1.0, 1.0, 6.0)  # one time constant: 1 - 1/e of the step
    np.testing.assert_allclose(state.pupil_mm, 4.0 + 2.0 * (1 - math.exp(-1)), rtol=1e-12)


class Screen:
    """A window stand-in: its colour is what a simulated eye's pupil answers to."""

    def __init__(self):
        self.color = (0.0, 0.0, 0.0)
        self.flips = 0

    def flip(self):
        self.flips += 1
        time.sleep(0.002)


class Eye:
    """A pupil of 3 mm on white and 7 mm on black, blinking (0) every fifth sample."""

    def __init__(self, screen):
        self.screen, self.n = screen, 0

    def sample(self):
        self.n += 1
        pupil = 0.0 if self.n % 5 == 0 else 5.0 - 2.0 * self.screen.color[0]
        return 10.0, 10.0, pupil


def test_calibrate_pupil_shows_white_then_black_and_maps_their_means():
    screen = Screen()
    with pytest.warns(UserWarning, match=r"screen_s=0\.05: Luidolt's pupil calibration .* 5 s"):
        c = calibrate_pupil(screen, Eye(screen), screen_s=0.05)  # a real pupil, unsettled
    assert (c.white_raw, c.black_raw) == (3.0, 7.0)  # blinks left out of both means
    assert screen.color == (0.0, 0.0, 0.0) and screen.flips > 4  # the colour put back


def test_a_simulated_pupil_calibration_is_moon_and_spencers_pupil_of_each_screen():
    # MouseGaze's pupil is a constant 5 mm: the simulated eye's is Moon & Spencer's of the
    # screen (200 and 0.05 cd/m²: 2.299 and 5.260 mm), blinks still left out, and recorded
    screen = Screen()
    c = calibrate_pupil(screen, Constant(), screen_s=0.03, simulate_cd_m2=(200.0, 0.05))
    assert (round(c.white_raw, 3), round(c.black_raw, 3)) == (2.299, 5.26)
    record = c.as_dict()
    assert record["screen_s"] == 0.03 and record["unit"] == "mm"
    assert min(record["valid_samples"]) > 0 and "Moon & Spencer" in record["simulated"]
    assert record["offset_mm"] + record["slope_mm_per_unit"] * c.black_raw == pytest.approx(8.0)
    with pytest.raises(ValueError, match="simulate_cd_m2 must be"):
        calibrate_pupil(screen, Constant(), screen_s=0.03, simulate_cd_m2=(0.05, 200.0))


class Constant:
    """MouseGaze: a constant 5 mm pupil, blinking (no pupil) every third sample."""

    def __init__(self):
        self.n = 0

    def sample(self):
        self.n += 1
        return 10.0, 10.0, None if self.n % 3 == 0 else 5.0


def test_iohubs_store_is_named_absolute_beside_the_session(tmp_path, monkeypatch):
    # ioHub's server runs in glarelab's package folder: a relative --out put the session's
    # _iohub.hdf5 there (src/glarelab/data/...), not beside its CSV
    monkeypatch.chdir(tmp_path)
    store = datastore_settings("data/P01_iohub.hdf5", "run1")
    assert store["datastore_name"] == str(tmp_path / "data" / "P01_iohub")
    assert store["session_code"] == "run1"
