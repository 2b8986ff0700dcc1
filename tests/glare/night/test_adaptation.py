"""Temporal adaptation (Luidolt 2020 §5.1, eqs. 5.1-5.4) against the paper's numbers and the
analytic properties of an exponential approach."""

import math
import warnings

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab.glare.night import adaptation


def test_rod_sensitivity_is_one_half_at_0_04_cd_m2():
    # Luidolt eq. 5.4: σ(Y) = 0.04 / (0.04 + Y)
    assert adaptation.rod_sensitivity(0.04) == 0.5
    assert adaptation.rod_sensitivity(0.0) == 1.0
    assert_allclose(adaptation.rod_sensitivity(1e9), 0.04 / (0.04 + 1e9), rtol=1e-15)


def test_time_constant_runs_from_cones_to_rods():
    # eq. 5.3 with τ_rod = 0.4 s, τ_cone = 0.1 s (§5.1)
    assert adaptation.adaptation_time_s(0.0) == pytest.approx(0.4, abs=1e-15)
    assert adaptation.adaptation_time_s(0.04) == pytest.approx(0.25, abs=1e-15)
    assert adaptation.adaptation_time_s(1e9) == pytest.approx(0.1, abs=1e-10)


@pytest.mark.parametrize("target", [0.0, 0.001, 0.04, 3.0, 1e4, 1e9])
@pytest.mark.parametrize("frames", [1, 7, 100])
def test_a_step_is_1_minus_1_over_e_done_after_one_time_constant(target, frames):
    # whatever the frame rate: after t = τ(Y), L = Y + (L0 - Y) / e
    start = 50.0
    tau = adaptation.adaptation_time_s(target)
    adapted = adaptation.adaptation_luminance(
        np.full(frames, target), tau / frames, initial_cd_m2=start
    )
    done = (adapted[-1] - start) / (target - start)
    assert_allclose(done, 1.0 - 1.0 / math.e, rtol=1e-12)


def test_frames_of_unequal_length_add_up():
    # exp(-a) exp(-b) = exp(-(a + b)): two frames of 0.1 and 0.3 s are one frame of 0.4 s
    two = adaptation.adaptation_luminance([0.01, 0.01], np.array([0.1, 0.3]), initial_cd_m2=5.0)
    one = adaptation.adaptation_luminance([0.01], 0.4, initial_cd_m2=5.0)
    assert_allclose(two[-1], one[-1], rtol=1e-13)


def test_without_an_initial_state_the_eye_starts_adapted():
    adapted = adaptation.adaptation_luminance([2.0, 2.0, 2.0], 1 / 60)
    assert_allclose(adapted, 2.0, rtol=0)


def test_a_zero_length_frame_changes_nothing():
    assert adaptation.adaptation_step(3.0, 0.0, 0.0) == 3.0


@settings(max_examples=200, deadline=None)
@given(
    targets=st.lists(
        st.one_of(st.just(0.0), st.just(1e9), st.floats(0.0, 1e9, allow_nan=False)),
        min_size=1,
        max_size=20,
    ),
    initial=st.one_of(st.none(), st.just(0.0), st.just(1e9), st.floats(0.0, 1e9)),
    frame_time=st.one_of(st.just(0.0), st.floats(0.0, 10.0)),
)
def test_adapted_luminance_stays_between_start_and_targets(targets, initial, frame_time):
    # black frames, 1e9 cd/m² frames, single-frame sequences: never NaN, never negative, never
    # past the range of what was seen
    adapted = adaptation.adaptation_luminance(targets, frame_time, initial_cd_m2=initial)
    seen = [*targets, targets[0] if initial is None else initial]
    assert adapted.shape == (len(targets),)
    assert np.isfinite(adapted).all() and (adapted >= 0).all()
    assert (adapted >= min(seen) * (1 - 1e-12)).all()
    assert (adapted <= max(seen) * (1 + 1e-12)).all()


def test_eq_5_1_is_colour_sciences_rec_709_luminance():
    # Poynton's coefficients as Luidolt prints them, against the Rec. 709 matrix we use
    rec709 = colour.RGB_COLOURSPACES["ITU-R BT.709"].matrix_RGB_to_XYZ[1]
    assert_allclose(adaptation.RGB_TO_Y_LUIDOLT2020, rec709, atol=2.5e-4)
    rgb = np.array([[3.0, 1.0, 0.5]])
    assert_allclose(
        adaptation.luminance(rgb), rgb @ np.array(adaptation.RGB_TO_Y_LUIDOLT2020), rtol=5e-4
    )


def test_frame_luminance_of_a_uniform_frame_is_its_luminance_wherever_the_gaze():
    image = np.full((40, 60, 3), 0.3)
    for gaze in (None, (0, 0), (20, 30), (-100, 500)):
        assert_allclose(
            adaptation.frame_luminance(image, pixel_deg=0.05, gaze_px=gaze), 0.3, rtol=1e-12
        )


def test_the_window_follows_the_gaze():
    # a lamp on the right: looking at it raises the adaptation luminance
    image = np.full((60, 200), 0.01)
    image[25:35, 170:180] = 1e4
    away = adaptation.frame_luminance(image, pixel_deg=0.05, gaze_px=(30, 20))
    at = adaptation.frame_luminance(image, pixel_deg=0.05, gaze_px=(30, 175))
    uniform = adaptation.frame_luminance(image, pixel_deg=0.05)
    assert away < uniform < at
    # a narrow window sees only the lamp, a very wide one the whole frame
    narrow = adaptation.frame_luminance(
        image, pixel_deg=0.05, gaze_px=(30, 175), window_sigma_deg=0.05
    )
    wide = adaptation.frame_luminance(
        image, pixel_deg=0.05, gaze_px=(30, 175), window_sigma_deg=1e4
    )
    assert narrow == pytest.approx(1e4, rel=1e-3)
    assert wide == pytest.approx(uniform, rel=1e-6)


def test_black_frames_and_a_single_pixel():
    black = np.zeros((3, 4, 3))
    # the log mean takes black as the absolute threshold of vision, 1e-6 cd/m²
    assert_allclose(adaptation.frame_luminance(black, pixel_deg=0.1, gaze_px=(1, 1)), 1e-6)
    assert adaptation.frame_luminance(black, pixel_deg=0.1, mean="arithmetic") == 0.0
    assert_allclose(
        adaptation.frame_luminance(np.array([[1e9]]), pixel_deg=1.0, gaze_px=(0, 0)), 1e9
    )


def test_a_small_lamp_does_not_make_the_night_day():
    # 4 pixels of a 5e4 cd/m² lamp in a 0.02 cd/m² street of 1536 pixels: the arithmetic mean
    # is 130 cd/m² (photopic), the log mean exp((4 ln 5e4 + 1532 ln 0.02) / 1536) = 0.0208
    street = np.full((32, 48), 0.02)
    street[10:12, 20:22] = 5e4
    arithmetic = adaptation.frame_luminance(street, pixel_deg=0.05, mean="arithmetic")
    log = adaptation.frame_luminance(street, pixel_deg=0.05)
    assert_allclose(arithmetic, (4 * 5e4 + 1532 * 0.02) / 1536, rtol=1e-12)
    assert_allclose(log, math.exp((4 * math.log(5e4) + 1532 * math.log(0.02)) / 1536), rtol=1e-12)


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: adaptation.rod_sensitivity(-1.0), "luminance_cd_m2"),
        (lambda: adaptation.rod_sensitivity(float("nan")), "luminance_cd_m2"),
        # a bool, a string and a complex number were read as 1, 100 and its real part
        (lambda: adaptation.rod_sensitivity(True), "luminance_cd_m2"),
        (
            lambda: adaptation.frame_luminance(np.ones((4, 4)), pixel_deg=0.1, gaze_px=(True, 2)),
            "gaze_px",
        ),
        (lambda: adaptation.rod_sensitivity("100"), "luminance_cd_m2"),
        (lambda: adaptation.rod_sensitivity(np.array([1.0, 2.0]) + 1j), "luminance_cd_m2"),
        (lambda: adaptation.rod_sensitivity(np.array([True, False])), "luminance_cd_m2"),
        (lambda: adaptation.adaptation_step(True, 1.0, 0.1), "previous_cd_m2"),
        (lambda: adaptation.adaptation_luminance(["1", "2"], 0.1), "targets_cd_m2"),
        (lambda: adaptation.adaptation_time_s(1.0, tau_rod_s=0.0), "tau_rod_s"),
        (lambda: adaptation.adaptation_step(1.0, 1.0, -0.1), "frame_time_s"),
        (lambda: adaptation.adaptation_step(-1.0, 1.0, 0.1), "previous_cd_m2"),
        (lambda: adaptation.adaptation_luminance([], 0.1), "targets_cd_m2"),
        (lambda: adaptation.adaptation_luminance([[1.0]], 0.1), "targets_cd_m2"),
        (lambda: adaptation.adaptation_luminance([1.0, 2.0], [0.1]), "frame_time_s"),
        (lambda: adaptation.adaptation_luminance([1.0], float("inf")), "frame_time_s"),
        (lambda: adaptation.frame_luminance(np.ones((2, 2)), pixel_deg=0.0), "pixel_deg"),
        (
            lambda: adaptation.frame_luminance(np.ones((2, 2)), pixel_deg=0.1, gaze_px=(1,)),
            "gaze_px",
        ),
        (
            lambda: adaptation.frame_luminance(
                np.ones((2, 2)), pixel_deg=0.1, gaze_px=(0, 0), window_sigma_deg=-1
            ),
            "window_sigma_deg",
        ),
        (lambda: adaptation.frame_luminance(-np.ones((2, 2)), pixel_deg=0.1), "image_cd_m2"),
        (lambda: adaptation.luminance(np.ones((2, 2))), "3 channels"),
        (
            lambda: adaptation.frame_luminance(np.ones((2, 2)), pixel_deg=0.1, mean="median"),
            "mean",
        ),
    ],
)
def test_bad_input_is_refused_by_name(call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call()


def test_a_window_of_zero_is_refused_without_a_gaze_too():
    # accepted (and unused) without a gaze, refused with one
    with pytest.raises(ValueError, match=r"^window_sigma_deg must be a finite number > 0 deg"):
        adaptation.frame_luminance(np.ones((4, 4)), pixel_deg=0.05, window_sigma_deg=0)


def test_a_bad_initial_state_is_named_as_given():
    # the error named adaptation_step's previous_cd_m2, an argument the caller never gave
    with pytest.raises(
        ValueError, match=r"^initial_cd_m2 must be a finite number >= 0 cd/m², got -1"
    ):
        adaptation.adaptation_luminance(np.array([1.0]), 0.1, initial_cd_m2=-1)


def test_an_infinite_frame_time_is_called_not_finite():
    # it said "frame_time_s must be in [0, inf] s, got inf", as if inf were allowed
    with pytest.raises(ValueError, match=r"frame_time_s must be a finite number >= 0 s, got inf"):
        adaptation.adaptation_step(1.0, 2.0, math.inf)


@pytest.mark.parametrize(
    ("frame_time_s", "shown"),
    [
        (True, "True"),  # was read as 1 s
        ("0.25", "'0.25'"),
        (np.ma.masked_array([0.25, 0.5, 0.25, 0.25], [0, 1, 0, 0]), "masked array"),
        ([0.25, "0.5", 0.25, 0.25], "'0.5' at position 1"),
    ],
)
def test_adaptation_luminance_refuses_frame_times_that_are_not_real_numbers(frame_time_s, shown):
    with pytest.raises(ValueError, match=f"^frame_time_s must .*{shown}"):
        adaptation.adaptation_luminance(np.full(4, 0.04), frame_time_s, initial_cd_m2=10.0)


@pytest.mark.parametrize(
    ("gaze", "expected"),
    [
        ((1e4, -1e4), 380.0),
        ((1e300, -1e300), 380.0),
        ((-1e308, -1e308), 0.0),
        ((10.0, 1e20), 219.0),
    ],
)
def test_a_gaze_however_far_off_the_frame_weights_its_nearest_pixels(gaze, expected):
    # the docs: the gaze may lie outside the image; beyond ~40 σ every weight underflowed and
    # the gaze was refused, and beyond 1e154 px the squares overflowed
    values = np.arange(400.0).reshape(20, 20)  # row r, column c: 20 r + c
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mean = adaptation.window_mean(values, pixel_deg=0.1, gaze_px=gaze, window_sigma_deg=0.05)
    assert_allclose(mean, expected, rtol=1e-12, atol=1e-12)
    uniform = adaptation.frame_luminance(np.full((20, 20), 7.0), pixel_deg=0.1, gaze_px=gaze)
    assert_allclose(uniform, 7.0, rtol=1e-12)
