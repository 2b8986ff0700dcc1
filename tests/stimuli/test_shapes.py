"""The disk on a uniform field: its geometry, and what cannot be one refused by name."""

from __future__ import annotations

import numpy as np
import pytest

from glarelab.stimuli.shapes import disk

GOOD = {
    "field_deg": 1.0,
    "pixel_deg": 0.1,
    "disk_diameter_deg": 0.3,
    "disk_cd_m2": 4000.0,
    "background_cd_m2": 150.0,
}


def test_the_disk_is_the_pixel_centres_within_its_radius_on_an_odd_field():
    stimulus = disk(**GOOD)
    assert stimulus["img"].shape == (11, 11)
    y, x = (np.indices((11, 11)) - 5) * 0.1
    np.testing.assert_array_equal(stimulus["mask"], np.hypot(x, y) <= 0.15)
    assert set(np.unique(stimulus["img"])) == {150.0, 4000.0}


@pytest.mark.parametrize(
    ("changes", "name"),
    [
        ({"disk_cd_m2": True}, "disk_cd_m2"),  # was a disk of 1 cd/m²
        ({"background_cd_m2": "150"}, "background_cd_m2"),  # was a TypeError from numpy
        ({"disk_cd_m2": float("inf")}, "disk_cd_m2"),
        ({"background_cd_m2": -1.0}, "background_cd_m2"),
        ({"disk_diameter_deg": 5.0}, "disk_diameter_deg"),  # was a field all disk
        ({"disk_diameter_deg": 1.0}, "disk_diameter_deg"),
        ({"pixel_deg": 3.0}, "pixel_deg"),  # was one pixel, its field 3°, not 1°
        ({"pixel_deg": True}, "pixel_deg"),
        ({"pixel_deg": 1e-9}, "pixel_deg"),  # was numpy's "array is too big"
    ],
)
def test_what_cannot_be_a_disk_on_its_field_is_refused_by_name(changes, name):
    with pytest.raises(ValueError, match=f"^{name}( must| = )"):
        disk(**(GOOD | changes))


@pytest.mark.parametrize("gap_px", [-1, 2.5, True])
def test_a_row_of_images_refuses_a_gap_that_is_no_pixel_count(gap_px):
    from glarelab.stimuli.shapes import ImageRow

    with pytest.raises(ValueError, match=r"^gap_px must be a whole number of pixels >= 0"):
        ImageRow(sizes_px=[(10, 10)], gap_px=gap_px)
