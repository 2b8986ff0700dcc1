"""The tracker's faults are held, clamped, smoothed and counted; Luidolt's pupil range."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from glarelab.frontend.eyetracker import (
    PUPIL_FILTER_S,
    GazeFilter,
    PupilCalibration,
    calibrate_pupil,
    datastore_settings,
)


def test_pupil_calibration_maps_white_to_2_and_black_to_8_mm():
    # Luidolt 2020 §5.2.1 ii: white-screen mean the minimum, black-screen mean the maximum
    c = PupilCalibration.from_samples([3.0, 0.0, 3.0, np.nan], [7.0, 7.0], unit="mm")
    assert (c.white_raw, c.black_raw) == (3.0, 7.0)  # the blink (0) and the lost (NaN) dropped
    np.testing.assert_allclose([c.to_mm(3.0), c.to_mm(5.0), c.to_mm(7.0)], [2.0, 5.0, 8.0])
    assert (c.to_mm(1.0), c.to_mm(20.0)) == (2.0, 8.0)  # clamped to Luidolt's range
    assert c.as_dict()["range_mm"] == [2.0, 8.0]


def test_a_tracker_without_pupil_range_is_refused():
    # MouseGaze reports 5 mm on both screens: no range to map
    with pytest.raises(ValueError, match="black_raw must exceed white_raw"):
        PupilCalibration.from_samples([5.0, 5.0], [5.0, 5.0])


def test_blinks_and_lost_samples_hold_the_last_state_and_are_counted():
    f = GazeFilter((200, 100), pupil_filter_s=0.0)
    f.update(0.0, 50.0, 40.0, 4.0)
    for t, sample in ((0.01, (None, None, 0.0)), (0.02, (None, None, None)),
                      (0.03, (math.nan, 1.0, math.nan))):  # fmt: skip
        state = f.update(t, *sample)
        assert (state.gaze_x_px, state.gaze_y_px, state.pupil_mm) == (50.0, 40.0, 4.0)
        assert not (state.valid_gaze or state.valid_pupil)
    assert f.counts() == {"samples": 4, "lost": 3, "blinks": 3, "off_screen": 0}


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
    c = calibrate_pupil(screen, Eye(screen), screen_s=0.05)
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
