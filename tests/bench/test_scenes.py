"""The bench's scenes are the scenes the issues name."""

import numpy as np

from glarelab.bench.scenes import WORKLOADS, workload


def test_workloads_are_the_scenes_the_issues_name():
    assert set(WORKLOADS) >= {"sun_2048", "sun_4096", "leaves_4096", "glints_4096"}
    # issue 13: a small image, a strip, an RGB city and a night scene with a sun-bright glint
    assert workload("street_256")[0].shape == (256, 256)
    assert workload("strip_4096x256")[0].shape == (256, 4096)
    city, _ = workload("city_rgb_2048")
    assert city.shape == (2048, 2048, 3) and (city.max(axis=2) > 220).sum() >= 300 * 4
    night, _ = workload("night_sun_2048")
    assert night.max() == 7.5e8 and (night > 220).sum() == 4 + 3 * 9
    sun, pixel = workload("sun_4096")
    assert sun.shape == (4096, 4096) and sun.max() == 7.5e8  # Spencer Fig. 16's sun
    radius_px = np.sqrt((sun == 7.5e8).sum() / np.pi)
    np.testing.assert_allclose(radius_px * pixel, 0.265, rtol=0.05)  # 0.53° across
    leaves, _ = workload("leaves_2048")
    assert (leaves == 4000.0).mean() > 0.05  # many bright pixels: the sky through the leaves
    assert workload("night_1280x1024")[0].shape == (1024, 1280)
    # issue 35: a city at night with 2,000 lamps, an RGB street and a sky with the sun, 1024²
    city, _ = workload("city_1024")
    assert city.shape == (1024, 1024) and (city > 220).sum() >= 2000 * 9 * 0.9
    street, _ = workload("street_rgb_1024")
    assert street.shape == (1024, 1024, 3) and not np.array_equal(street[..., 0], street[..., 2])
    assert workload("sun_1024")[0].max() == 7.5e8
