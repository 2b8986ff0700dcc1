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
        (
            lambda: ap.aperture_diaphragm(GRID, 4.0, 6, prefilter=(4, 3)),
            r"prefilter must be \(subsamples, smoothing\).*got \(4, 3\)",
        ),
        (lambda: ap.prefilter_weights((3, 0)), "prefilter must be"),
        (lambda: ap.prefilter_weights((1.5, 1)), "prefilter must be"),
        (lambda: ap.ApertureGrid(64, 0.0), "spacing_mm must be a finite number > 0"),
        (lambda: ap.aperture_cross_screen(GRID, "star"), "kind must be one of"),
    ],
)
def test_bad_parameters_are_named(call, match):
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize("sides", [3, 4, 7])
@pytest.mark.parametrize("rotation_deg", [0.0, 45.0, 13.0])
def test_prefiltered_diaphragm_is_the_weighted_cover_of_its_sub_cells(sides, rotation_deg):
    # every sample the prefilter's weights over the cover of all its 13² sub-cells, the way
    # aperture_diaphragm draws samples away from the edges (0 or 1) and along one edge
    # (that edge alone) included
    grid, prefilter = ap.ApertureGrid(61, 0.05), (5, 3)
    t = ap.aperture_diaphragm(grid, 2.5, sides, rotation_deg=rotation_deg, prefilter=prefilter)
    weights, cell = ap.prefilter_weights(prefilter), grid.spacing_mm / 5
    offsets = (np.arange(weights.size) - weights.size // 2) * cell
    x, y = grid.coordinates()
    px = x[..., None, None] + offsets[None, None, None, :]
    py = y[..., None, None] + offsets[None, None, :, None]
    cover = np.ones(px.shape)
    apothem = 1.25 * math.cos(math.pi / sides)
    for k in range(sides):
        angle = math.radians(rotation_deg) + (k + 0.5) * 2 * math.pi / sides
        inside = apothem - (px * math.cos(angle) + py * math.sin(angle))
        cover = np.minimum(cover, ap.half_plane_coverage(inside, angle, cell))
    assert_allclose(t, np.einsum("abij,i,j->ab", cover, weights, weights), atol=1e-12)


def test_prefilter_transfer_is_the_weights_spectrum_and_shrinks_the_streaks_copies():
    # Φ(ε) = sinc(ε/r) (sin(π ε) / (r sin(π ε/r)))^q = sinc(ε/r) (sinc(ε) / sinc(ε/r))^q: the
    # sub-cell box times q boxes of r sub-cells
    epsilon = np.linspace(-2.0, 2.0, 41)
    weights = ap.prefilter_weights((5, 3))
    assert_allclose(weights.sum(), 1.0)
    assert_allclose([weights[k::5].sum() for k in range(5)], 0.2)  # each sub-cell: 1/r
    closed = np.sinc(epsilon / 5) * (np.sinc(epsilon) / np.sinc(epsilon / 5)) ** 3
    assert_allclose(ap.prefilter_transfer(epsilon, (5, 3)), closed, atol=1e-14)
    assert_allclose(ap.prefilter_transfer(epsilon), np.sinc(epsilon), atol=1e-15)
    # a streak falls off as 1/f: its copies 1/δ apart carry Σ_j |Φ(ε+j) ε / (Φ(ε) (ε+j))| of
    # its amplitude; at the border of a kernel a third of the period wide, ε = 1/6. For the
    # box, |Φ(ε+j)/Φ(ε)| = ε/|ε+j| and the sum is ε² Σ 1/(ε+j)² = (πε / sin πε)² - 1
    epsilon, j = 1 / 6, np.concatenate([np.arange(-4000, 0), np.arange(1, 4001)])

    def copies(prefilter):
        ratio = ap.prefilter_transfer(epsilon + j, prefilter) / ap.prefilter_transfer(
            np.array(epsilon), prefilter
        )
        return float(np.sum(np.abs(ratio) * epsilon / np.abs(epsilon + j)))

    box = (np.pi * epsilon / np.sin(np.pi * epsilon)) ** 2 - 1  # 0.0966
    assert_allclose(copies((1, 1)), box, rtol=1e-3)
    assert_allclose(copies((5, 3)), 0.0065, atol=1e-4)


@pytest.mark.parametrize(
    ("sides", "rotation_deg", "eyelid", "cross_screen"),
    [(5, 0.0, True, None), (4, 45.0, False, "4-point"), (6, 0.0, True, "4-point"),
     (3, 10.0, True, "trigonal")],
)  # fmt: skip
def test_diaphragm_behind_lid_and_cross_screen_is_the_weighted_cover_of_its_sub_cells(
    sides, rotation_deg, eyelid, cross_screen
):
    # every sample the prefilter's weights over the product of the obstacles' covers of its
    # 13² sub-cells: the fast paths (no edge near, one obstacle's edge alone, the 4-point
    # screen's two axis-aligned sets filtered apart) give the same as all sub-cells
    grid, prefilter = ap.ApertureGrid(81, 0.07), (5, 3)
    t = ap.aperture_diaphragm_prefiltered(
        grid, 5.0, sides, rotation_deg=rotation_deg, eyelid=eyelid, cross_screen=cross_screen,
        prefilter=prefilter,
    )  # fmt: skip
    weights, cell = ap.prefilter_weights(prefilter), grid.spacing_mm / 5
    offsets = (np.arange(weights.size) - weights.size // 2) * cell
    x, y = grid.coordinates()
    px = x[..., None, None] + offsets[None, None, None, :]
    py = y[..., None, None] + offsets[None, None, :, None]
    cover = ap._Polygon(5.0, sides, rotation_deg).cover(px, py, cell)
    if eyelid:  # the lid's margin, 2.2 mm above the centre, curved with a 12 mm radius
        sag = 12.0 - np.sqrt(12.0**2 - px**2)
        cover *= np.clip(0.5 + ((2.2 - sag) - py) / cell, 0.0, 1.0)
    sets = {"4-point": 2, "trigonal": 3}.get(cross_screen, 0)
    for k in range(sets):  # lines of 0.03 mm every 0.25 mm, each sub-cell's exact cover
        angle = math.radians(k * 180.0 / sets)
        d = (px * math.cos(angle) + py * math.sin(angle) + 0.125) % 0.25 - 0.125
        line = ap.half_plane_coverage(0.015 - d, angle, cell)
        cover *= 1.0 - (line - ap.half_plane_coverage(-0.015 - d, angle, cell))
    # the 4-point screen's two sets filtered apart: exact where they cross (a separable
    # filter of a product of a function of x and one of y); the table of an edge's filtered
    # profile: within 1e-6
    assert_allclose(t, np.einsum("abij,i,j->ab", cover, weights, weights), atol=1e-6)


def test_round_pupil_behind_a_bitmap_is_the_weighted_cover_of_its_sub_cells():
    # a round pupil of 4.8 mm (each sub-cell by its ramp) behind a random bitmap of 0.2 mm
    # pixels read as area coverage (each sub-cell's overlap with each pixel, summed here
    # directly), the lid and a 4-point screen: every sample the prefilter's weights over the
    # sub-cells
    rng = np.random.default_rng(3)
    image = np.where(rng.random((25, 23)) < 0.3, rng.random((25, 23)), 1.0)
    grid, prefilter, spacing = ap.ApertureGrid(41, 0.125), (5, 3), 0.2
    t = ap.aperture_diaphragm_prefiltered(
        grid, 4.8, None, eyelid=True, cross_screen="4-point", obstacle_image=image,
        obstacle_spacing_mm=spacing, prefilter=prefilter,
    )  # fmt: skip
    weights, cell = ap.prefilter_weights(prefilter), grid.spacing_mm / 5
    offsets = (np.arange(weights.size) - weights.size // 2) * cell
    x, y = grid.coordinates()
    px, py = np.broadcast_arrays(
        x[..., None, None] + offsets[None, None, None, :],
        y[..., None, None] + offsets[None, None, :, None],
    )
    cover = np.clip(0.5 + (ap.ramp_radius_mm(2.4, cell) - np.hypot(px, py)) / cell, 0.0, 1.0)

    def overlaps(centre, pixels):  # each sub-cell's overlap with each pixel along one axis
        edges = (np.arange(pixels + 1) - pixels // 2 - 0.5) * spacing
        low = np.clip(centre[..., None] - cell / 2, edges[:-1], edges[1:])
        return (np.clip(centre[..., None] + cell / 2, edges[:-1], edges[1:]) - low) / cell

    cover *= 1.0 + ((overlaps(-py, 25) @ (image - 1.0)) * overlaps(px, 23)).sum(axis=-1)
    sag = 12.0 - np.sqrt(12.0**2 - px**2)  # the lid 2.2 mm up, curved with a 12 mm radius
    cover *= np.clip(0.5 + ((2.2 - sag) - py) / cell, 0.0, 1.0)
    for angle in (0.0, math.pi / 2):  # lines of 0.03 mm every 0.25 mm
        d = (px * math.cos(angle) + py * math.sin(angle) + 0.125) % 0.25 - 0.125
        line = ap.half_plane_coverage(0.015 - d, angle, cell)
        cover *= 1.0 - (line - ap.half_plane_coverage(-0.015 - d, angle, cell))
    assert_allclose(t, np.einsum("abij,i,j->ab", cover, weights, weights), atol=1e-6)


@pytest.mark.parametrize(
    ("spacing", "prefilter"), [(0.013, (1, 1)), (0.05, (5, 3)), (0.11, (3, 2))]
)
def test_an_image_read_as_area_coverage_blocks_its_bitmaps_area(spacing, prefilter):
    # each pixel a square of its value: the samples' blocked area is the bitmap's, whatever
    # the two spacings and the prefilter
    rng = np.random.default_rng(1)
    image = rng.random((40, 33))
    t = ap.aperture_image_cover(ap.ApertureGrid(160, 0.037), image, spacing, prefilter=prefilter)
    blocked = (1.0 - t).sum() * 0.037**2
    assert_allclose(blocked, (1.0 - image).sum() * spacing**2, rtol=1e-12)
