import re
import tomllib
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.protocols import load_protocol, parse_protocol, pixel_deg
from glarelab.stimuli.backgrounds import background
from glarelab.stimuli.exr import write_exr
from glarelab.stimuli.matching import build_matching, compose_target
from glarelab.stimuli.staircase import build_staircase
from glarelab.stimuli.stimulus_set import compose

PROTOCOLS = Path(__file__).parents[2] / "src" / "glarelab" / "protocols"


@pytest.fixture(scope="module")
def yoshida():
    protocol = load_protocol("yoshida2008")
    return protocol, build_matching(protocol)


@pytest.fixture(scope="module")
def spencer():
    protocol = load_protocol("spencer1995")
    return protocol, build_staircase(protocol)


def test_yoshida_geometry_matches_the_protocol(yoshida):
    protocol, built = yoshida
    images, p = built["images"], pixel_deg(protocol)
    coverage = images["target_coverage"]["img"]
    # disk diameter in pixels = 0.3° × pixels per degree, within one pixel
    diameter_px = 2 * np.sqrt(coverage.sum() / np.pi)
    assert abs(diameter_px - 0.3 / p) < 1.0
    size = images["background"]["img"].shape[0]
    assert abs(size - 3.2 / p) <= 1.0 and size % 2 == 1


def test_yoshida_background_mean_is_150(yoshida):
    _, built = yoshida
    assert_allclose(built["images"]["background"]["img"].mean(), 150.0, rtol=0.01)


def test_yoshida_references_stay_at_or_below_l_dmax(yoshida):
    protocol, built = yoshida
    for name, info in built["images"].items():
        if info["kind"] == "reference":
            assert info["img"].max() <= protocol["glare"]["l_dmax_cd_m2"] + 1e-9, name


def test_glare_free_levels_equal_the_plain_disk(yoshida):
    _, built = yoshida
    images = built["images"]
    plain = compose_target(
        images["target_background"]["img"], images["target_coverage"]["img"], 220.0
    )
    for name in ("reference_gaussian_A", "reference_vos_a"):
        assert_allclose(images[name]["img"], plain, rtol=0, atol=1e-9)
    # and a glaring level differs from the plain disk, more at the higher levels
    boost = [(images[f"reference_gaussian_{x}"]["img"] - plain).sum() for x in "BCDEF"]
    assert all(b > 0 for b in boost) and np.all(np.diff(boost) > 0)


def test_spencer_windows_peak_and_levels(spencer):
    protocol, built = spencer
    peak = protocol["glare"]["peak_fraction"] * protocol["display"]["max_cd_m2"]
    glare_images = [v for v in built["images"].values() if v["kind"] == "glare"]
    assert len(glare_images) == 12 * 2
    for info in glare_images:
        assert info["img"].shape == (300, 300)
        assert_allclose(info["img"].max(), peak, rtol=1e-12)  # §4: peak at 75 % of maximum
    # glare grows with level: light outside the source
    none = [built["images"][f"glare_none_{k:02d}"]["img"] for k in range(1, 13)]
    outside = [img.sum() - img[140:161, 140:161].sum() for img in none]
    assert np.all(np.diff(outside) > 0)


def test_spencer_comparison_has_a_one_third_annulus(spencer):
    protocol, built = spencer
    images = built["images"]
    full = images["comparison_none_full"]["img"]
    maximum = protocol["display"]["max_cd_m2"]
    assert full[150, 150] == pytest.approx(maximum)
    annulus = images["comparison_annulus"]["img"]
    ring = annulus > 0.999
    assert_allclose(full[ring], maximum / 3, rtol=1e-9)


def test_the_comparison_is_a_sum_of_set_images(spencer):
    from glarelab.protocols.staircase import comparison_terms
    from glarelab.stimuli.staircase import compose_comparison

    protocol, built = spencer
    images = {name: info["img"] for name, info in built["images"].items()}
    for context in ("none", "lamp"):
        terms = comparison_terms(context, 61.5, protocol["stimulus"]["annulus_ratio"])
        expected = compose_comparison(
            images[f"scene_{context}"],
            images["comparison_disc"],
            images["comparison_annulus"],
            61.5,
            protocol["stimulus"]["annulus_ratio"],
        )
        assert_allclose(compose(terms, images.__getitem__), expected, rtol=0, atol=1e-12)


def test_a_uniform_background_and_a_users_exr(tmp_path):
    rng = np.random.default_rng(0)
    flat = background({"kind": "uniform", "cd_m2": 12.5}, (5, 7), pixel_deg=0.1, rng=rng,
                      ceiling_cd_m2=220.0)  # fmt: skip
    assert flat.shape == (5, 7) and (flat == 12.5).all()
    gradient = np.tile(np.arange(40, dtype=np.float32), (30, 1))  # 0.02°/px, 0.8° × 0.6°
    write_exr(tmp_path / "mine.exr", gradient)
    spec = {"kind": "exr", "path": "mine.exr", "pixel_deg": 0.02}
    same = background(spec, (10, 20), pixel_deg=0.02, rng=rng, ceiling_cd_m2=220.0,
                      folder=tmp_path)  # fmt: skip
    assert_allclose(same, gradient[10:20, 10:30])  # cut from the centre, as it is
    coarse = background(spec, (5, 10), pixel_deg=0.04, rng=rng, ceiling_cd_m2=220.0,
                        folder=tmp_path)  # fmt: skip
    assert coarse.shape == (5, 10)
    assert_allclose(coarse.mean(), gradient[5:25, 0:40].mean(), rtol=0.05)  # luminance kept
    with pytest.raises(ValueError, match=r"covers 0\.8° × 0\.6° .*the stimulus needs 2° × 2°"):
        background(spec, (100, 100), pixel_deg=0.02, rng=rng, ceiling_cd_m2=220.0,
                   folder=tmp_path)  # fmt: skip
    with pytest.raises(ValueError, match="above 20 cd/m² where glare is added"):
        background(spec, (10, 20), pixel_deg=0.02, rng=rng, ceiling_cd_m2=20.0,
                   folder=tmp_path)  # fmt: skip


def _bilinear(image, y, x):
    """The image at (row, column) y, x, read bilinearly, the border pixel held beyond it."""
    y = min(max(y, 0.0), image.shape[0] - 1.0)
    x = min(max(x, 0.0), image.shape[1] - 1.0)
    y0, x0 = min(int(y), image.shape[0] - 2), min(int(x), image.shape[1] - 2)
    fy, fx = y - y0, x - x0
    patch = image[y0 : y0 + 2, x0 : x0 + 2]
    return (1 - fy) * ((1 - fx) * patch[0, 0] + fx * patch[0, 1]) + fy * (
        (1 - fx) * patch[1, 0] + fx * patch[1, 1]
    )


@pytest.mark.parametrize(
    ("file_px", "file_deg", "shape", "pixel_deg"),
    [((16, 16), 0.2, (161, 161), 0.2 * 16 / 160.6),  # a field 161 px ≈ exactly the file
     ((30, 40), 0.02, (7, 9), 0.07),  # the file finer than the field's pixels
     ((9, 11), 0.5, (40, 50), 0.1)],  # the file coarser
)  # fmt: skip
def test_an_exr_is_read_at_each_pixel_centre(tmp_path, file_px, file_deg, shape, pixel_deg):
    """The field's pixel centres, aligned on the file's centre, read bilinearly: a file that
    covers the field exactly was refused ('covers 3.2° × 3.2°, needs 3.2° × 3.2°': the zoomed
    file came out a pixel short), and a coarse one was zoomed whole (1024 px of 1° pixels:
    'not enough memory')."""
    rng = np.random.default_rng(1)
    image = rng.uniform(1.0, 100.0, file_px).astype(np.float32)
    write_exr(tmp_path / "f.exr", image)
    spec = {"kind": "exr", "path": "f.exr", "pixel_deg": file_deg}
    got = background(spec, shape, pixel_deg=pixel_deg, rng=rng, ceiling_cd_m2=220.0,
                     folder=tmp_path)  # fmt: skip
    assert got.shape == shape
    centre = [(n - 1) / 2 for n in file_px]
    for i, j in [(0, 0), (shape[0] - 1, shape[1] - 1), (shape[0] // 2, 1), (1, shape[1] - 2)]:
        y = (i - (shape[0] - 1) / 2) * pixel_deg / file_deg + centre[0]
        x = (j - (shape[1] - 1) / 2) * pixel_deg / file_deg + centre[1]
        assert_allclose(got[i, j], _bilinear(image.astype(float), y, x), rtol=1e-12)
    wider = (shape[0], int(np.ceil(file_px[1] * file_deg / pixel_deg)) + 2)  # past its edge
    with pytest.raises(ValueError, match=r"f\.exr covers .*background\.pixel_deg"):
        background(spec, wider, pixel_deg=pixel_deg, rng=rng, ceiling_cd_m2=220.0,
                   folder=tmp_path)  # fmt: skip


def test_a_coarse_exr_is_not_zoomed_whole(tmp_path):
    write_exr(tmp_path / "big.exr", np.full((1024, 1024), 50.0, np.float32))
    spec = {"kind": "exr", "path": "big.exr", "pixel_deg": 1.0}
    got = background(spec, (542, 542), pixel_deg=0.0059, rng=np.random.default_rng(0),
                     ceiling_cd_m2=220.0, folder=tmp_path)  # fmt: skip
    assert_allclose(got, 50.0, rtol=1e-14)


def test_wave_optics_glare_around_a_disk_on_a_uniform_field(tmp_path):
    data = tomllib.loads((PROTOCOLS / "yoshida2008.toml").read_text())
    data["stimulus"].update(size_deg=1.0, supersample=1)
    data["background"] = {"kind": "uniform", "cd_m2": 20.0}
    data["glare"]["methods"] = [
        {
            "name": "wave",
            "model": "wave",
            "parameters": {"pupil_mm": 4.0, "particles": 0, "seed": 3},
            "labels": ["w1", "w2"],
            "levels_cd_m2": [220.0, 5000.0],
        }
    ]
    data["analysis"] = {}
    built = build_matching(parse_protocol(data))["images"]
    low, high = built["reference_wave_w1"]["img"], built["reference_wave_w2"]["img"]
    plain = compose_target(
        built["target_background"]["img"], built["target_coverage"]["img"], 220.0
    )
    assert_allclose(low, plain, atol=1e-9)  # nothing above L_dmax: no glare
    ring = high - plain
    assert ring.min() >= -1e-9 and ring.sum() > 0  # glare light around the disk


@pytest.mark.parametrize(
    ("options", "named"),
    [({"cloud_min_deg": 2.0, "cloud_max_deg": 0.05}, "cloud_min_deg = 2.0 must be above 0 and below"),
     ({"ceiling_cd_m2": 50.0}, "mean_cd_m2 = 100.0 must be above 0 and below ceiling_cd_m2 = 50.0")],
)  # fmt: skip
def test_a_sky_that_cannot_be_what_is_asked_is_refused(options, named):
    """Each made a sky: the sizes reversed gave the mean asked, the ceiling below the mean a
    flat 50 cd/m² for a sky of 100."""
    from glarelab.stimuli.sky import cloudy_sky

    asked = {"mean_cd_m2": 100.0, "contrast": 0.2, "cloud_min_deg": 0.05,
             "cloud_max_deg": 2.0, "slope": 1.0, "ceiling_cd_m2": 1000.0} | options  # fmt: skip
    with pytest.raises(ValueError, match=re.escape(named)):
        cloudy_sky((64, 64), pixel_deg=0.01, rng=np.random.default_rng(1), **asked)


def test_a_negative_uniform_background_is_refused():
    with pytest.raises(ValueError, match=r"uniform background's cd_m2 must be >= 0; got -5\.0"):
        background({"kind": "uniform", "cd_m2": -5.0}, (4, 6), pixel_deg=0.01,
                   rng=np.random.default_rng(0), ceiling_cd_m2=100.0)  # fmt: skip


def test_clouds_smaller_than_two_pixels_are_refused_by_their_size():
    """The build said the ceiling cut the sky's contrast: no cloud could be drawn at all."""
    spec = {"kind": "sky", "mean_cd_m2": 150.0, "contrast": 0.15, "cloud_min_deg": 0.001,
            "cloud_max_deg": 0.002, "spectrum_slope": 1.0}  # fmt: skip
    with pytest.raises(ValueError, match=r"cloud_max_deg = 0\.002° is under two pixels"):
        background(spec, (32, 32), pixel_deg=0.0059, rng=np.random.default_rng(0),
                   ceiling_cd_m2=220.0)  # fmt: skip


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: compose_target(np.zeros(2), np.array([0.5, 1.1]), 1000.0), "coverage must hold"),
        (lambda: compose_target(np.zeros(2), np.ones(2), float("nan")), "disk_cd_m2 must be a"),
        (lambda: compose_target(np.zeros(2), np.ones(2), -1.0), "disk_cd_m2 must be a finite"),
        (lambda: compose_target(np.zeros(3), np.ones(2), 1.0), "must have one shape"),
    ],
)
def test_a_target_no_disk_makes_is_refused(call, match):
    """A coverage of 1.1 gave a 1000 cd/m² disk a 2100 cd/m² pixel, a NaN disk a NaN target."""
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize("factor", [0, 2.0, True, -1])
def test_a_box_filter_factor_that_is_no_whole_number_is_refused(factor):
    from glarelab.stimuli.matching import box_filter

    with pytest.raises(ValueError, match=r"^factor must be a whole number >= 1"):
        box_filter(np.ones((4, 4)), factor)
