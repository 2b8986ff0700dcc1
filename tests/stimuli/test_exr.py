import numpy as np
import pytest
from numpy.testing import assert_array_equal

from glarelab.stimuli.exr import read_exr, write_exr
from glarelab.stimuli.preview import to_display
from glarelab.stimuli.shapes import disk


@pytest.mark.parametrize("shape", [(7, 5), (7, 5, 3)])
def test_float32_round_trip_is_exact_including_huge_luminances(tmp_path, shape):
    rng = np.random.default_rng(0)
    image = rng.uniform(0, 1, shape).astype(np.float32) * np.float32(1e9)  # > half's 65504
    path = write_exr(tmp_path / "a.exr", image)
    back = read_exr(path)
    assert back.dtype == np.float32 and back.shape == shape
    assert_array_equal(back, image)


def test_bad_images_and_paths_are_refused(tmp_path):
    with pytest.raises(ValueError, match=r"got shape \(2, 2, 2\)"):
        write_exr(tmp_path / "b.exr", np.zeros((2, 2, 2)))
    with pytest.raises(ValueError, match="NaN or Inf"):
        write_exr(tmp_path / "c.exr", np.full((2, 2), np.nan))
    with pytest.raises(FileNotFoundError, match="no EXR file"):
        read_exr(tmp_path / "missing.exr")


def test_display_preview_encodes_srgb_and_clips():
    image = np.array([[0.0, 22.0, 220.0, 1e6]])
    codes = to_display(image, l_dmax_cd_m2=220.0)
    # sRGB: 0 → 0, 10 % → 0.349 (IEC 61966-2-1), white and above → 255
    assert codes.tolist() == [[0, 89, 255, 255]]
    log = to_display(image, l_dmax_cd_m2=220.0, scale="log", decades=4)
    assert log[0, 1] == round(255 * 3 / 4)
    with pytest.raises(ValueError, match="scale must be one of"):
        to_display(image, l_dmax_cd_m2=220.0, scale="gamma")


def test_disk_geometry():
    s = disk(
        field_deg=3.2,
        pixel_deg=0.01,
        disk_diameter_deg=0.3,
        disk_cd_m2=4000.0,
        background_cd_m2=150.0,
    )
    n = s["img"].shape[0]
    assert n % 2 == 1 and s["img"][n // 2, n // 2] == 4000.0
    area_deg2 = s["mask"].sum() * 0.01**2
    assert abs(area_deg2 - np.pi * 0.15**2) / (np.pi * 0.15**2) < 0.02
    with pytest.raises(ValueError, match="disk_cd_m2 must be a finite number >= 0"):
        disk(field_deg=1, pixel_deg=0.1, disk_diameter_deg=0.3, disk_cd_m2=-1, background_cd_m2=0)


def test_a_float16_image_is_written_without_a_warning(tmp_path):
    """The check against float32's largest cast 3.4e38 to float16: 'overflow encountered in
    cast', an error under warnings-as-errors for a valid image."""
    import warnings

    image = np.full((2, 2), 3.0, np.float16)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        write_exr(tmp_path / "half.exr", image)
    np.testing.assert_array_equal(read_exr(tmp_path / "half.exr"), image.astype(np.float32))
