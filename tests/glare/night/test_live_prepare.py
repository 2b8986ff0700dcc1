"""LiveNight.prepare makes, before the first frame, every bank entry a gaze on the scene needs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from glarelab.files import memory
from glarelab.glare.night.adaptation import ABSOLUTE_THRESHOLD_CD_M2, luminance, window_mean
from glarelab.glare.night.live import LiveNight

PIXEL_DEG = 0.1
SHAPE = (20, 28)


def scene_of(rng: np.random.Generator) -> np.ndarray:
    """A dark street with a bright half, a uniform wall and two lamps: targets over a range of
    30×, and a plateau that makes the bank halve the intervals around it."""
    scene = np.full((*SHAPE, 3), 0.01) * rng.uniform(0.5, 2.0, size=(*SHAPE, 1))
    scene[:, SHAPE[1] // 2 :] *= 30.0
    scene[:10, 20:] = 0.3
    scene[3:5, 4:6] = 5e4
    scene[14:16, 22:24] = 2e3
    return scene


@pytest.fixture(scope="module")
def scene():
    return scene_of(np.random.default_rng(7))


def test_the_range_is_the_windowed_target_at_every_gaze_on_the_scene(scene):
    # σ = 0.6° is 6 pixels: the grid of σ/8 is every pixel, and the range is exact
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, window_sigma_deg=0.6)
    y = np.log(np.maximum(luminance(scene), ABSOLUTE_THRESHOLD_CD_M2))  # eq. 5.1, log mean
    targets = [
        math.exp(window_mean(y, pixel_deg=PIXEL_DEG, gaze_px=(r, c), window_sigma_deg=0.6))
        for r in range(SHAPE[0])
        for c in range(SHAPE[1])
    ]
    np.testing.assert_allclose(live.adaptation_range(), (min(targets), max(targets)), rtol=1e-12)


def test_an_initial_adaptation_outside_the_targets_widens_the_range(scene):
    low, high = LiveNight(scene, pixel_deg=PIXEL_DEG).adaptation_range()
    start = LiveNight(scene, pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=high * 50)
    assert start.adaptation_range() == (low, high * 50)


frames = st.lists(
    st.tuples(
        st.one_of(
            st.none(),
            st.tuples(
                st.floats(0.0, SHAPE[0] - 1.0, allow_nan=False),
                st.floats(0.0, SHAPE[1] - 1.0, allow_nan=False),
            ),
            st.sampled_from([(0.0, 0.0), (SHAPE[0] - 1.0, SHAPE[1] - 1.0), (0.0, SHAPE[1] - 1.0)]),
        ),
        st.one_of(
            st.none(), st.just(0.0), st.sampled_from([2.0, 2.99, 3.0, 8.0]), st.floats(2.0, 8.0)
        ),
        st.sampled_from([0.0, 1 / 90, 1 / 60, 0.1, 10.0]),
    ),
    min_size=1,
    max_size=6,
)


@pytest.fixture(scope="module")
def prepared(scene):
    """Both pipelines prepared once, with the smallest bank the class allows (the preparation
    must grow it) and a window small enough for the target to follow the gaze over the range
    of the scene; the examples then replay frames on the same bank."""
    made = {}
    for acuity in (False, True):
        live = LiveNight(
            scene, pixel_deg=PIXEL_DEG, acuity=acuity, scotopic=acuity, bank_size=4,
            threshold_ratio=1.1, window_sigma_deg=0.6, band_budget_deg2=0.005,
        )  # fmt: skip
        made[acuity] = (live, live.prepare())
    return made


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(path=frames, acuity=st.booleans())
def test_no_frame_on_the_scene_makes_an_entry_after_the_preparation(prepared, path, acuity):
    live, preparation = prepared[acuity]
    assert preparation.entries > 4 and live.bank_entries == preparation.entries
    assert max(live._halvings(base) for base in range(-60, 60)) > 1  # halved intervals too
    live._state, live._gaze, live._pupil = None, None, None  # a new viewer, the same bank
    for gaze, pupil, frame_time_s in path:
        frame = live.frame(gaze_px=gaze, pupil_mm=pupil, frame_time_s=frame_time_s)
        assert frame.new_entries == 0, (gaze, pupil, frame.adaptation_cd_m2)
    assert live.bank_entries == preparation.entries


def test_progress_counts_every_entry_and_a_second_preparation_makes_none(scene):
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, threshold_ratio=1.1)
    seen = []
    first = live.prepare(progress=lambda made, total: seen.append((made, total)))
    assert seen == [(made, first.entries) for made in range(first.entries + 1)]
    assert first.bytes == first.entries * SHAPE[0] * SHAPE[1] * 3 * 4  # float32 RGB
    assert live.prepare().entries == 0


def test_a_bank_beyond_the_memory_is_refused_before_any_entry(scene, monkeypatch):
    monkeypatch.setattr(memory, "available_memory", lambda: 1000)
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, threshold_ratio=1.1)
    with pytest.raises(ValueError, match="bank entries"):
        live.prepare()
    assert live.bank_entries == 0
