from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from stimuli.protocol import load_protocol, pixel_deg
from stimuli.spencer1995 import build_spencer1995
from stimuli.yoshida2008 import compose_target

PROTOCOLS = Path(__file__).parents[2] / "protocols"


@pytest.fixture(scope="module")
def yoshida():
    from stimuli.yoshida2008 import build_yoshida2008

    protocol = load_protocol(PROTOCOLS / "yoshida2008.toml")
    return protocol, build_yoshida2008(protocol)


@pytest.fixture(scope="module")
def spencer():
    protocol = load_protocol(PROTOCOLS / "spencer1995.toml")
    return protocol, build_spencer1995(protocol)


def test_yoshida_geometry_matches_the_protocol(yoshida):
    protocol, built = yoshida
    images, p = built["images"], pixel_deg(protocol)
    coverage = images["target_coverage"]["img"]
    # disk diameter in pixels = 0.3° × pixels per degree, within one pixel
    diameter_px = 2 * np.sqrt(coverage.sum() / np.pi)
    assert abs(diameter_px - 0.3 / p) < 1.0
    size = images["sky"]["img"].shape[0]
    assert abs(size - 3.2 / p) <= 1.0 and size % 2 == 1


def test_yoshida_background_mean_is_150(yoshida):
    _, built = yoshida
    assert_allclose(built["images"]["sky"]["img"].mean(), 150.0, rtol=0.01)


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
