"""The lamp scene at its boundary: its randomness only through a generator, and a peak that
is a positive luminance (a negative one drew a scene of negative luminances)."""

import numpy as np
import pytest

from glarelab.stimuli.backgrounds import lamp_scene


@pytest.mark.parametrize("rng", [0, None, np.random.RandomState(0)])
def test_a_lamp_scene_drawn_without_a_generator_is_refused_naming_rng(rng):
    message = r"^rng must be a numpy.random.Generator \(np.random.default_rng\(seed\)\); got"
    with pytest.raises(ValueError, match=message):
        lamp_scene(32, rng=rng, peak_cd_m2=100.0)


@pytest.mark.parametrize("peak", [-1.0, 0.0, float("nan"), float("inf"), "100", True])
def test_a_lamp_scene_of_no_positive_peak_is_refused(peak):
    with pytest.raises(ValueError, match=r"^peak_cd_m2"):
        lamp_scene(32, rng=np.random.default_rng(0), peak_cd_m2=peak)
    assert lamp_scene(32, rng=np.random.default_rng(0), peak_cd_m2=100.0)["img"].min() >= 0
