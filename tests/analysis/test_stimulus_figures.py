"""The figures' helpers refuse what no image is: a white of 0 or NaN (a NaN figure), negative
luminances (shown as black), a centre outside the image (empty profiles, no word)."""

from __future__ import annotations

import numpy as np
import pytest

from glarelab.analysis.stimulus_figures import radial_profile, to_srgb8


@pytest.mark.parametrize("white", [0.0, float("nan"), -5.0, True])
def test_a_white_that_is_no_luminance_is_refused(white):
    with pytest.raises(ValueError, match=r"^max_cd_m2 must be a finite luminance above 0"):
        to_srgb8(np.array([1.0, 2.0]), white)


def test_a_negative_luminance_is_refused_not_shown_black():
    with pytest.raises(ValueError, match=r"^luminance_cd_m2 must hold finite luminances >= 0"):
        to_srgb8(np.array([-1.0, 2.0]), 100.0)


@pytest.mark.parametrize("centre", [(10.0, 2.0), (-1.0, 2.0), (float("nan"), 2.0)])
def test_a_centre_outside_the_image_is_refused_not_an_empty_profile(centre):
    with pytest.raises(ValueError, match=r"^centre_px must be \(row, column\) inside the 5 × 5"):
        radial_profile(np.ones((5, 5)), centre, 0.1)
    distance, mean = radial_profile(np.ones((5, 5)), (2.0, 2.0), 0.1)
    assert distance.size == mean.size == 3
