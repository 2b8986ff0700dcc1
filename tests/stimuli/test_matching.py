"""The matching builder's helpers at their boundary: the box filter keeps an image's colour
channels (it reshaped them away, or failed), and a target's disk luminance is checked where
its terms are made as where the target is composed."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab.stimuli.matching import box_filter, compose_target, target_terms


@settings(max_examples=60, deadline=None)
@given(
    height=st.integers(1, 13),
    width=st.integers(1, 13),
    channels=st.sampled_from([None, 1, 3]),
    factor=st.integers(1, 5),
)
def test_box_filter_is_the_mean_of_each_block_in_every_channel(height, width, channels, factor):
    shape = (height, width) if channels is None else (height, width, channels)
    image = np.random.default_rng(height * 100 + width).random(shape)
    filtered = box_filter(image, factor)
    rows, columns = height // factor, width // factor
    assert filtered.shape == (rows, columns, *shape[2:])
    for i in range(rows):
        for j in range(columns):
            block = image[i * factor : (i + 1) * factor, j * factor : (j + 1) * factor]
            assert_allclose(filtered[i, j], block.mean(axis=(0, 1)), rtol=1e-12)


@pytest.mark.parametrize("image", [np.zeros(6), np.zeros((2, 2, 2, 2)), "image", None])
def test_box_filter_refuses_what_is_not_an_image(image):
    with pytest.raises(ValueError, match=r"^image must be"):
        box_filter(image, 2)


@pytest.mark.parametrize("disk", [-1.0, float("nan"), float("inf"), True, "120", None])
def test_target_terms_refuse_a_disk_luminance_compose_target_refuses(disk):
    message = r"^disk_cd_m2 must be a finite luminance >= 0, cd/m²"
    with pytest.raises(ValueError, match=message):
        target_terms(disk)
    with pytest.raises(ValueError, match=message):
        compose_target(np.zeros(2), np.zeros(2), disk)
    assert target_terms(np.float32(120.0)) == [
        ("target_background", 1.0),
        ("target_coverage", 120.0),
    ]
