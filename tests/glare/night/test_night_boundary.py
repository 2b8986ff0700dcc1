"""render_night at its boundary: its adaptation time constants are judged by themselves and
named, whatever else is missing."""

import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from glarelab import glare
from glarelab.glare.night.pipeline import render_night

from ..strategies import NOT_A_NUMBER, NOT_FINITE_POSITIVE, SETTINGS

SCENE = np.full((8, 8), 0.05)


@SETTINGS
@given(
    name=st.sampled_from(["tau_rod_s", "tau_cone_s"]),
    value=st.one_of(NOT_A_NUMBER, NOT_FINITE_POSITIVE),
    frame_time_s=st.sampled_from([None, 0.1]),
)
def test_a_time_constant_that_is_not_positive_is_refused_naming_it(name, value, frame_time_s):
    # render_night([img] * 2, tau_rod_s=0) was refused for the missing frame_time_s, and
    # tau_rod_s = 0 itself never judged
    with pytest.raises(ValueError, match=rf"^{name} must be a finite number > 0 s, got") as raised:
        render_night([SCENE, SCENE], pixel_deg=0.05, frame_time_s=frame_time_s, **{name: value})
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize(
    ("options", "named"),
    [
        ({"effects": ("glare", "glare")}, "effects = ('glare', 'glare'): glare given twice"),
        ({"effects": "glare"}, "effects = 'glare': must be a sequence of names"),
        ({"frame_time_s": [0.1, 0.1]}, "frame_time_s: 2 durations for 3 frames"),
        ({"desaturation": 0.3}, "desaturation = 0.3: only Spencer's scotopic colour takes it"),
        (
            {"initial_adaptation_cd_m2": -1.0, "frame_time_s": None},
            "initial_adaptation_cd_m2 must be a finite number >= 0 cd/m², got -1",
        ),
    ],
)
def test_effects_given_twice_durations_for_other_frames_or_an_ignored_option_are_refused(
    options, named
):
    # a repeated effect was applied once without a word, and two durations for three frames
    # ended in numpy's broadcasting error, naming no argument
    with pytest.raises(ValueError, match=re.escape(named)):
        render_night([SCENE] * 3, pixel_deg=0.05, **({"frame_time_s": 0.1} | options))


@pytest.mark.parametrize(
    ("option", "match"),
    [
        ({"blur": "fast"}, r"^blur must be one of 'layers', 'separable', 'exact'; got 'fast'$"),
        ({"adaptation_mean": "median"}, r"^adaptation_mean must be one of 'log', 'arithmetic'"),
    ],
)
def test_a_method_is_refused_under_its_own_argument_name(option, match):
    # the lower functions' names came through: "method must be ...", "mean must be ..."
    image = np.full((16, 16, 3), 0.05)
    image[8, 8] = 5000.0
    with pytest.raises(ValueError, match=match):
        render_night(image, pixel_deg=0.05, **option)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        # numpy's 'operands could not be broadcast together with remapped shapes'
        (lambda: glare.adaptation_luminance(np.array([1.0, 2.0]), np.array([0.1, 0.1, 0.1])),
         r"^frame_time_s must be a number or one per frame \(2\); got shape \(3,\)"),
        # numpy's 'setting an array element with a sequence'
        (lambda: glare.pupil_diameter_mm([[1.0, 2.0], [3.0]]),
         r"^field_luminance_cd_m2 must be an array of numbers; got rows of different lengths"),
        # 'embedded null byte', from the file system
        (lambda: glare.digitise_kernel("vos", 0.05, (5, 5), cache="kernels\0"),
         r"^cache must name a folder; got 'kernels\\x00'"),
    ],
)  # fmt: skip
def test_a_wrong_shape_or_name_is_refused_naming_the_argument(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_an_unknown_colourspace_is_refused_for_a_grey_image_too():
    with pytest.raises(ValueError, match="colourspace"):
        glare.frame_luminance(np.full((20, 20), 3.0), pixel_deg=0.1, colourspace="sRGB-ish")


@pytest.mark.parametrize(
    ("option", "effect"),
    [
        ({"glare_model": "hybrid"}, "glare"),
        ({"glare_method": "Spencer1995"}, "glare"),
        ({"tolerance_codes": 0.0}, "glare"),
        ({"glare_falloff_deg": 2.0, "gaze_px": (4, 4)}, "glare"),
        ({"pupil_from_adaptation": False}, "glare"),
        ({"acuity_method": "Luidolt2020"}, "acuity"),
        ({"blur": "exact"}, "acuity"),
        ({"levels_per_octave": 4}, "acuity"),
        ({"acuity_space": "linear"}, "acuity"),
        ({"scotopic_method": "Spencer1995"}, "scotopic"),
        ({"initial_adaptation_cd_m2": 1.0}, "adaptation"),
        ({"tau_rod_s": 5.0}, "adaptation"),
        ({"tau_cone_s": 0.2}, "adaptation"),
        ({"frame_time_s": 0.1}, "adaptation"),
    ],
)
def test_an_option_of_an_effect_left_out_is_refused_naming_it_and_the_effect(option, effect):
    # render_night(effects=('adaptation',), glare_model='hybrid') equalled the render
    # without it: the options of an effect left out were taken and ignored
    others = tuple(e for e in glare.night.EFFECTS if e != effect)
    name = next(k for k in option if k != "gaze_px")
    with pytest.raises(
        ValueError, match=rf"^{name}=.*the effect '{effect}' is left out"
    ) as raised:
        render_night([SCENE] * 2, pixel_deg=0.05, effects=others, **option)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize(
    ("option", "match"),
    [
        ({"tau_rod_s": 5.0}, r"^tau_rod_s=5.0: one frame without initial_adaptation_cd_m2"),
        ({"tau_cone_s": 0.2}, r"^tau_cone_s=0.2: one frame without initial_adaptation_cd_m2"),
        ({"frame_time_s": 0.1}, r"^frame_time_s=0.1: one frame without initial_adaptation"),
        ({"glare_model": "gaussian", "pupil_from_adaptation": False},
         r"^pupil_from_adaptation=False with glare_model='gaussian': the model has no pupil"),
        ({"blur": "exact", "levels_per_octave": 4},
         r"^levels_per_octave=4 with blur='exact': it spaces the 'layers' ladder"),
        ({"glare_method": "bogus"}, r"^glare_method must be one of 'Yoshida2008'"),
        ({"acuity_space": "bogus"}, r"^acuity_space must be one of 'lightness', 'linear'"),
        ({"window_sigma_deg": 0}, r"^window_sigma_deg must be a finite number > 0 deg, got 0"),
        ({"window_sigma_deg": 20.0}, r"^window_sigma_deg=20.0 without a gaze \(gaze_px\)"),
        ({"window_sigma_deg": 1.0, "gaze_px": [None]}, r"^window_sigma_deg=1.0 without a gaze"),
    ],
)  # fmt: skip
def test_an_option_that_would_be_ignored_or_is_bad_is_refused_under_its_own_name(option, match):
    # one frame has no adaptation dynamics, the Gaussian no pupil, the exact blur no ladder:
    # each was taken and ignored; a bad glare_method or acuity_space was named as the
    # renderer's "composition" or the blur's "space", a zero window without a gaze accepted
    with pytest.raises(ValueError, match=match) as raised:
        render_night(SCENE, pixel_deg=0.05, **option)
    assert "\n" not in str(raised.value)


def test_the_pupil_reported_is_the_one_the_glare_was_rendered_for():
    # the hybrid model reported NaN though its wave part has a pupil each frame
    scene = np.full((16, 16, 3), 0.05)
    scene[8, 8] = 5e4
    hybrid = render_night(scene, pixel_deg=0.1, glare_model="hybrid")
    assert hybrid.pupil_mm.tolist() == [hybrid.models[0].wave.pupil_mm] == [5.2]
    vos = render_night(scene, pixel_deg=0.1)
    assert vos.pupil_mm.tolist() == [vos.models[0].pupil_mm]
    assert np.isnan(render_night(scene, pixel_deg=0.1, glare_model="gaussian").pupil_mm).all()


def test_an_unknown_glare_model_is_named_as_given():
    # the error named the renderer's "model", not the glare_model the caller gave
    with pytest.raises(ValueError, match=r"^glare_model must be one of 'Yoshida2008'"):
        render_night(SCENE, pixel_deg=0.05, glare_model="bogus")
