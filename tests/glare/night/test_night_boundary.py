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
            "initial_adaptation_cd_m2 must be in [0, inf) cd/m², got -1",
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
