import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.glare.models import apertures as ap

GRID = ap.ApertureGrid(512, 0.02)  # 10.24 mm


@pytest.mark.parametrize("diameter", [2.0, 4.0, 8.0])
def test_pupil_area(diameter):
    area = ap.aperture_pupil(GRID, diameter).sum() * GRID.spacing_mm**2
    assert_allclose(area, math.pi * diameter**2 / 4, rtol=2e-3)  # antialiased edge


def test_diaphragm_area_and_symmetry():
    t = ap.aperture_diaphragm(GRID, 6.0, 6)
    area = t.sum() * GRID.spacing_mm**2
    assert_allclose(area, 3 * math.sqrt(3) / 2 * 3.0**2, rtol=2e-3)  # hexagon, circumradius 3
    assert_allclose(t, t[:, ::-1][:, np.r_[-1, 0 : GRID.n - 1]], atol=1e-9)  # mirror in x


def test_eyelid_blocks_above_the_margin():
    t = ap.aperture_eyelid(GRID, upper_mm=1.0)
    centre = GRID.n // 2
    assert t[centre - int(1.5 / 0.02), centre] == 0.0  # 1.5 mm above the centre: lid
    assert t[centre, centre] == 1.0
    assert t[centre - int(0.5 / 0.02), centre] == 1.0


def test_eyelashes_are_seeded_opaque_lines():
    a = ap.aperture_eyelashes(GRID, rng=np.random.default_rng(1))
    b = ap.aperture_eyelashes(GRID, rng=np.random.default_rng(1))
    c = ap.aperture_eyelashes(GRID, rng=np.random.default_rng(2))
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert a.min() == 0.0 and a.max() == 1.0
    left = ap.aperture_eyelashes(GRID, rng=np.random.default_rng(1), eye="left")
    assert not np.array_equal(a, left)
    assert ap.aperture_eyelashes(GRID, rng=np.random.default_rng(1), count=0).min() == 1.0


def test_particles_block_their_area():
    count, size = 200, 0.1
    t = ap.aperture_particles(GRID, rng=np.random.default_rng(0), count=count, size_mm=size)
    blocked = (1 - t).sum() * GRID.spacing_mm**2
    expected = count * math.pi * size**2 / 4
    assert 0.8 * expected < blocked <= 1.02 * expected  # overlaps only reduce it


def test_cross_screens_have_their_line_sets():
    four = ap.aperture_cross_screen(GRID, "4-point")
    assert_allclose(four, four.T, atol=1e-9)  # two perpendicular sets
    trigonal = ap.aperture_cross_screen(GRID, "trigonal")
    assert trigonal.mean() < four.mean() < 1.0


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (np.ones((4, 4, 2)), "must be a 2-D transmittance image"),
        (np.full((4, 4), np.nan), "must be finite"),
        (np.full((4, 4), 1.5), r"in \[0, 1\]; got values from 1.5"),
        (np.full((4, 4), -0.1), r"in \[0, 1\]"),
    ],
)
def test_bad_aperture_images_are_refused(image, match):
    with pytest.raises(ValueError, match=match):
        ap.aperture_from_image(image)


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: ap.aperture_pupil(GRID, 0.0), "diameter_mm must be a finite number > 0"),
        (lambda: ap.aperture_pupil(GRID, -2.0), "diameter_mm"),
        (lambda: ap.aperture_diaphragm(GRID, 4.0, 2), "sides must be an integer >= 3"),
        (lambda: ap.ApertureGrid(64, 0.0), "spacing_mm must be a finite number > 0"),
        (lambda: ap.aperture_cross_screen(GRID, "star"), "kind must be one of"),
    ],
)
def test_bad_parameters_are_named(call, match):
    with pytest.raises(ValueError, match=match):
        call()
