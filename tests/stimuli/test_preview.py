"""Previews of luminance images and kernels: what cannot be shown is refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from glarelab.stimuli.preview import psf_to_display, to_display

IMAGE = np.array([[0.0, 50.0], [100.0, 400.0]])


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: to_display(IMAGE, l_dmax_cd_m2=0.0), "l_dmax_cd_m2"),  # was all white
        (lambda: to_display(IMAGE, l_dmax_cd_m2=-100.0), "l_dmax_cd_m2"),  # was all black
        (lambda: to_display(np.array([[np.nan, 1.0]]), l_dmax_cd_m2=1.0), "luminance_cd_m2"),
        (lambda: to_display(np.array([["50", "1"]]), l_dmax_cd_m2=100.0), "luminance_cd_m2"),
        (lambda: to_display(np.ones((2, 2, 4)), l_dmax_cd_m2=1.0), "luminance_cd_m2"),
        (lambda: to_display(IMAGE, l_dmax_cd_m2=100.0, scale="log", decades=0), "decades"),
        (lambda: to_display(IMAGE, l_dmax_cd_m2=100.0, decades=2), "decades"),  # ignored
        (lambda: to_display(IMAGE, l_dmax_cd_m2=100.0, scale="linear"), "scale"),
        (lambda: psf_to_display(np.ones((3, 3)), dynamic_range=0), "dynamic_range"),
        (lambda: psf_to_display(np.ones((3, 3)), peak=-1.0), "peak"),  # was all white
        (lambda: psf_to_display(np.full((3, 3), np.nan)), "values"),
    ],
)
def test_what_cannot_be_shown_is_refused_by_name(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_the_display_scale_and_the_log_scale_show_what_they_say():
    np.testing.assert_array_equal(to_display(IMAGE, l_dmax_cd_m2=100.0), [[0, 188], [255, 255]])
    log = to_display(
        np.array([[1e-3, 1e-1, 1.0, 10.0]]), l_dmax_cd_m2=10.0, scale="log", decades=4
    )
    np.testing.assert_array_equal(log, [[0, 128, 191, 255]])


def test_a_preview_under_another_suffix_is_refused(tmp_path):
    """PNG bytes were written to ``x.jpg``."""
    from glarelab.stimuli.preview import preview_png, psf_png

    with pytest.raises(ValueError, match=r"^path must name a \.png file; got '.*x\.jpg'"):
        preview_png(tmp_path / "x.jpg", np.ones((2, 2)), l_dmax_cd_m2=220.0)
    with pytest.raises(ValueError, match=r"^path must name a \.png file"):
        psf_png(tmp_path / "k.tif", np.ones((3, 3)))
    assert list(tmp_path.iterdir()) == []
