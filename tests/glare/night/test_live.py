"""The per-frame night renderer equals the offline render_night of the same gaze and pupil."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from glarelab.glare import VosGlare, render_night
from glarelab.glare.models.eye import regime
from glarelab.glare.night.live import LiveNight, pupil_bank_mm
from glarelab.glare.night.pipeline import eye_state_model
from glarelab.glare.rendering.display import CodeTable, display_codes, display_lut
from glarelab.stimuli.night import night_street

PIXEL_DEG = 0.1
L_DMAX = 100.0


@pytest.fixture(scope="module")
def scene():
    return night_street((72, 48), pixel_deg=PIXEL_DEG, rng=np.random.default_rng(3))["img"]


def codes(image):
    return display_codes(image, display_lut(None, L_DMAX))


def eye(pupil_mm, adaptation_cd_m2, model=None):
    """The Vos model of a live frame: its pupil, and the regime of its L_i (Spencer §3.1)."""
    return eye_state_model(
        VosGlare() if model is None else model,
        pupil_mm=pupil_mm,
        regime=regime(adaptation_cd_m2),
    )


def offline(scene, frame, previous, frame_time_s):
    """render_night of one frame from the live frame's gaze, pupil and previous state."""
    return render_night(
        scene, pixel_deg=PIXEL_DEG, effects=("adaptation", "glare"),
        glare_model=eye(frame.pupil_mm, frame.adaptation_cd_m2), pupil_from_adaptation=False,
        gaze_px=frame.gaze_px, frame_time_s=frame_time_s, initial_adaptation_cd_m2=previous,
        display_max_cd_m2=L_DMAX, tolerance_codes=0.0,
    )  # fmt: skip


def test_frames_equal_render_night_within_half_a_code(scene):
    # corners, a pupil between the bank's entries on either side of the halo's 3 mm step, a
    # blink (pupil 0, no gaze: both held) and a dark start that moves the adaptation far
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=0.3)
    h, w = scene.shape[:2]
    steps = [((0, 0), 2.7), ((h - 1, w - 1), 3.3), (None, 0.0), ((0, w - 1), 5.25),
             ((h - 1, 0), 7.9)]  # fmt: skip
    previous, seen = 0.3, []
    for gaze, pupil in steps:
        frame = live.frame(gaze_px=gaze, pupil_mm=pupil, frame_time_s=0.05)
        reference = offline(scene, frame, previous, 0.05)
        np.testing.assert_allclose(
            frame.adaptation_cd_m2, reference.adaptation_cd_m2[0], rtol=1e-12
        )
        error = np.abs(codes(frame.image) - codes(reference.frames)).max()
        assert error < 0.5, (gaze, pupil, error)
        previous = frame.adaptation_cd_m2
        seen.append((frame.gaze_px, frame.pupil_mm))
    assert seen[2] == seen[1]  # the blink held the last gaze and pupil
    # the frames differ from one another by far more than the tolerance: the test can see
    assert np.abs(codes(frame.image) - codes(offline(scene, frame, 0.3, 0.05).frames)).max() > 5


def test_a_pupil_on_a_bank_entry(scene):
    live = LiveNight(scene, pixel_deg=PIXEL_DEG)
    frame = live.frame(gaze_px=(10, 10), pupil_mm=5.5, frame_time_s=0.0)
    assert (
        np.abs(codes(frame.image) - codes(offline(scene, frame, None, None).frames)).max() < 0.01
    )


def test_pupil_bank_holds_both_sides_of_the_halo_step():
    bank = pupil_bank_mm(VosGlare(), (2.0, 2.5, 3.5))
    assert bank[2] < 3.0 <= bank[3] and bank[3] - bank[2] < 1e-12


def test_bad_pupil_is_refused(scene):
    live = LiveNight(scene, pixel_deg=PIXEL_DEG)
    with pytest.raises(ValueError, match="pupil_mm must lie within the bank, 2-8 mm"):
        live.frame(gaze_px=(0, 0), pupil_mm=9.0, frame_time_s=0.0)


def test_the_threshold_is_interpolated_between_the_bank_levels(scene):
    # thresholds an octave apart: the frame still follows render_night (measured 0.12 codes)
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, threshold_ratio=2.0)
    frame = live.frame(gaze_px=(0, 0), pupil_mm=5.0, frame_time_s=0.0)
    assert np.abs(codes(frame.image) - codes(offline(scene, frame, None, None).frames)).max() < 0.2


def test_the_bank_is_denser_where_a_plateau_of_the_scene_meets_the_threshold():
    # a wall of one luminance between two of the bank's levels (r^20.6, r = 1.02) and a lamp:
    # the threshold at the wall puts 1280 pixels (12.8 deg²) on the kink of Yoshida's eq. 1,
    # where the interpolation in T errs most; measured 0.67 codes with levels 2 % apart only,
    # 0.17 with the interval halved twice (the budget: 0.005 × 12.8 deg² <= 0.08)
    wall = 1.02**20.6
    scene = np.full((48, 72, 3), 0.02)
    scene[20:22, 10:12] = 5e4
    scene[8:40, 30:70] = wall
    reference = render_night(
        scene, pixel_deg=PIXEL_DEG, effects=("adaptation", "glare"),
        glare_model=eye(5.0, wall / 10.0), pupil_from_adaptation=False, gaze_px=(0.0, 0.0),
        initial_adaptation_cd_m2=wall / 10.0, frame_time_s=0.0, tolerance_codes=0.0,
    ).frames  # fmt: skip
    errors = {}
    for budget in (None, 0.08):
        live = LiveNight(
            scene, pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=wall / 10.0,
            band_budget_deg2=budget,
        )  # fmt: skip
        frame = live.frame(gaze_px=(0, 0), pupil_mm=5.0, frame_time_s=0.0)
        errors[budget] = np.abs(codes(frame.image) - codes(reference)).max()
    assert errors[None] > 0.5  # the old spacing: the test can see the kink
    assert errors[0.08] < 0.25, errors
    assert live._halvings(20) == 2 and live._halvings(0) == 0  # only where the wall is


def test_the_gaze_falloff_equals_render_nights_and_keeps_the_glare_near_the_gaze(scene):
    # Luidolt §5.2.3: the glared frame blended with the unglared one by a Gaussian falloff
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, glare_falloff_deg=1.0)
    frame = live.frame(gaze_px=(0, 0), pupil_mm=4.0, frame_time_s=0.0)
    options = dict(
        pixel_deg=PIXEL_DEG, effects=("adaptation", "glare"),
        glare_model=eye(4.0, frame.adaptation_cd_m2), pupil_from_adaptation=False, gaze_px=(0.0, 0.0), tolerance_codes=0.0,
    )  # fmt: skip
    reference = render_night(scene, glare_falloff_deg=1.0, **options).frames
    assert np.abs(codes(frame.image) - codes(reference)).max() < 0.5
    full = render_night(scene, **options).frames
    bare = np.minimum(scene * frame.exposure, L_DMAX)
    near, far = np.s_[:1, :1], np.s_[-5:, -5:]  # the gaze (weight 1) and the far corner
    np.testing.assert_allclose(frame.image[near], full[near], atol=1e-3)  # all the glare
    np.testing.assert_allclose(frame.image[far], bare[far], atol=1e-3)  # and ≈ 0 here
    assert np.abs(full[far] - bare[far]).max() > 1.0  # where the full frame has glare


def test_spencers_sum_equals_render_nights(scene):
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, glare_method="Spencer1995")
    frame = live.frame(gaze_px=(20, 30), pupil_mm=2.5, frame_time_s=0.0)
    reference = render_night(
        scene, pixel_deg=PIXEL_DEG, effects=("adaptation", "glare"), glare_method="Spencer1995",
        glare_model=eye(2.5, frame.adaptation_cd_m2), pupil_from_adaptation=False,
        gaze_px=(20.0, 30.0),
        tolerance_codes=0.0,
    )  # fmt: skip
    assert np.abs(codes(frame.image) - codes(reference.frames)).max() < 0.5


def test_scotopic_colour_of_the_adapted_luminance_equals_render_nights(scene):
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, scotopic=True, initial_adaptation_cd_m2=0.5)
    frame = live.frame(gaze_px=(47, 0), pupil_mm=6.0, frame_time_s=0.05)
    reference = render_night(
        scene, pixel_deg=PIXEL_DEG, effects=("adaptation", "glare", "scotopic"),
        glare_model=eye(6.0, frame.adaptation_cd_m2), pupil_from_adaptation=False,
        gaze_px=(47.0, 0.0),
        frame_time_s=0.05, initial_adaptation_cd_m2=0.5, tolerance_codes=0.0,
    )  # fmt: skip
    assert np.abs(codes(frame.image) - codes(reference.frames)).max() < 0.5
    unshifted = LiveNight(scene, pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=0.5)
    plain = unshifted.frame(gaze_px=(47, 0), pupil_mm=6.0, frame_time_s=0.05).image
    assert np.abs(codes(plain) - codes(reference.frames)).max() > 5  # the shift is visible


def border_lamp_scene():
    """A dim street with a lamp cut by the left border and an orange window."""
    scene = np.full((40, 56, 3), 0.05)
    scene[18:21, 0:2] = 3e4
    scene[5:9, 30:40] *= [4.0, 1.0, 0.3]
    return scene


@pytest.mark.parametrize("adaptation_cd_m2", [30.0, 0.3, 0.003])  # photopic, mesopic, scotopic
@pytest.mark.parametrize("which", ["street", "border"])
def test_acuity_and_scotopic_colour_equal_render_nights(scene, which, adaptation_cd_m2):
    # Luidolt §5.3-5.4 per frame from the bank: measured within 2e-4 codes of render_night
    image = scene if which == "street" else border_lamp_scene()
    live = LiveNight(
        image, pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=adaptation_cd_m2, acuity=True,
        scotopic=True,
    )  # fmt: skip
    for gaze, pupil in (((0.0, 0.0), 2.7), ((20.0, 30.0), 5.25)):
        before = live._state
        frame = live.frame(gaze_px=gaze, pupil_mm=pupil, frame_time_s=0.02)
        reference = render_night(
            image, pixel_deg=PIXEL_DEG, glare_model=eye(pupil, frame.adaptation_cd_m2),
            pupil_from_adaptation=False, gaze_px=gaze, frame_time_s=0.02,
            initial_adaptation_cd_m2=before, tolerance_codes=0.0, display_max_cd_m2=L_DMAX,
        )  # fmt: skip
        error = np.abs(codes(frame.image) - codes(reference.frames)).max()
        assert error < 0.5, (gaze, pupil, error)
    plain = render_night(
        image, pixel_deg=PIXEL_DEG, effects=("adaptation", "glare"),
        glare_model=eye(5.25, frame.adaptation_cd_m2), pupil_from_adaptation=False,
        gaze_px=(20.0, 30.0),
        frame_time_s=0.02, initial_adaptation_cd_m2=before, tolerance_codes=0.0,
    ).frames  # fmt: skip
    if adaptation_cd_m2 < 1.0:  # the two effects are visible at night (little by day)
        assert np.abs(codes(frame.image) - codes(plain)).max() > 2


def test_pixels_that_meet_the_white_between_two_levels_are_blurred_directly(scene):
    # thresholds 5 % apart: the bank's interpolation alone errs by 5.7 codes where a channel
    # meets L_dmax between the two levels; those pixels and their neighbours are blurred
    # from the frame itself (measured 0.28 codes, the rest from the glare's interpolation)
    live = LiveNight(
        scene, pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=0.3, acuity=True,
        threshold_ratio=1.05,
    )  # fmt: skip
    frame = live.frame(gaze_px=(0, 0), pupil_mm=5.0, frame_time_s=0.0)
    reference = render_night(
        scene, pixel_deg=PIXEL_DEG, effects=("adaptation", "glare", "acuity"),
        glare_model=eye(5.0, frame.adaptation_cd_m2), pupil_from_adaptation=False,
        gaze_px=(0.0, 0.0), initial_adaptation_cd_m2=0.3, frame_time_s=0.0, tolerance_codes=0.0,
    )  # fmt: skip
    assert frame.exact_px > 0
    assert np.abs(codes(frame.image) - codes(reference.frames)).max() < 0.5


def test_acuity_with_the_gaze_falloff_is_refused(scene):
    with pytest.raises(ValueError, match="acuity=True does not combine with glare_falloff_deg"):
        LiveNight(scene, pixel_deg=PIXEL_DEG, acuity=True, glare_falloff_deg=2.0)


@pytest.mark.parametrize("gaze", ["16,16", (16.0, 16.0, 1.0), (True, 3.0), [[1.0, 2.0]]])
def test_a_gaze_that_is_not_two_numbers_is_refused(gaze):
    # '16,16' was read as the gaze (1, 6): a string's first two characters
    live = LiveNight(np.ones((8, 8)), pixel_deg=0.1, pupils_mm=(4.0,))
    with pytest.raises(ValueError, match=r"gaze_px must be \(row, column\), two numbers"):
        live.frame(gaze_px=gaze, pupil_mm=4.0, frame_time_s=0.0)


@pytest.mark.parametrize(
    ("options", "named"),
    [
        ({"bank_size": 4.5}, "bank_size must be an integer >= 4; got 4.5"),
        ({"bank_size": True}, "bank_size must be an integer >= 4; got True"),
        ({"acuity_method": "Luidolt2020"}, "without acuity=True: the acuity loss is off"),
    ],
)
def test_a_fractional_bank_or_acuity_options_without_acuity_are_refused(options, named):
    # bank_size 4.5 was truncated to 4, and the acuity options were ignored without a word
    with pytest.raises(ValueError, match=re.escape(named)):
        LiveNight(np.ones((8, 8)), pixel_deg=0.1, pupils_mm=(4.0,), **options)


@pytest.mark.parametrize(
    ("scotopic", "colourspace"),
    [(True, "ITU-R BT.709"), (False, "ITU-R BT.709"), (True, "ITU-R BT.2020")],
)
def test_frames_encoded_while_the_kinks_are_blurred_equal_frames_encoded_after(
    scene, scotopic, colourspace
):
    # the codes (and the scotopic colour) of the frame are made while the second core blurs
    # the pixels near a kink, and theirs after: the same image and the same codes as encoding
    # the finished frame (BT.2020's rod weights < 0 take scotopic_colour after the blur)
    table = CodeTable(display_lut(None, L_DMAX))
    options = dict(
        pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=0.3, acuity=True, scotopic=scotopic,
        threshold_ratio=1.05, colourspace=colourspace,
    )  # fmt: skip
    fused, plain = LiveNight(scene, **options), LiveNight(scene, **options)
    exact = 0
    for gaze, pupil in (((0.0, 0.0), 5.0), ((20.0, 30.0), 2.5), ((47.0, 71.0), 7.0)):
        encoded = fused.frame(gaze_px=gaze, pupil_mm=pupil, frame_time_s=0.05, encode=table)
        frame = plain.frame(gaze_px=gaze, pupil_mm=pupil, frame_time_s=0.05)
        np.testing.assert_array_equal(encoded.image, frame.image)
        np.testing.assert_array_equal(encoded.codes, table(frame.image))
        assert frame.codes is None
        exact += encoded.exact_px
    assert exact > 0  # some pixels were blurred directly


def test_a_pupil_that_drops_the_halo_unsets_its_wavelength_in_a_live_frame(scene):
    """A mesopic 500 nm model behind a 2.5 mm pupil from the eye tracker: the frame's model
    would refuse the wavelength (no halo under 3 mm), so the live mode unsets it."""
    model = VosGlare(regime="mesopic", wavelength_nm=500.0)
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, glare_model=model)
    small = live.frame(gaze_px=(20, 30), pupil_mm=2.5, frame_time_s=0.0)
    bare = LiveNight(scene, pixel_deg=PIXEL_DEG, glare_model=VosGlare(regime="mesopic"))
    np.testing.assert_array_equal(
        small.image, bare.frame(gaze_px=(20, 30), pupil_mm=2.5, frame_time_s=0.0).image
    )
    large = live.frame(gaze_px=(20, 30), pupil_mm=5.0, frame_time_s=0.0)
    assert np.isfinite(large.image).all()


def test_a_frame_takes_the_vos_regime_of_its_adaptation_as_render_night_does():
    # a mesopic frame (L_i 0.73 cd/m²) was rendered with the photopic PSF, the model's
    # default: 151 codes from render_night of the same pupil and adaptation (no halo)
    scene = np.random.default_rng(3).uniform(0.01, 2.0, (48, 64, 3))
    scene[20, 30], scene[5, 60] = 3e4, 1e4
    reference = render_night(
        scene, pixel_deg=PIXEL_DEG, effects=("adaptation", "glare"), gaze_px=(20.0, 30.0),
        initial_adaptation_cd_m2=0.5, frame_time_s=0.1, tolerance_codes=0.0,
    )  # fmt: skip
    pupil = float(reference.pupil_mm[0])
    live = LiveNight(
        scene, pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=0.5, pupils_mm=(3, pupil)
    )
    frame = live.frame(gaze_px=(20, 30), pupil_mm=pupil, frame_time_s=0.1)
    assert regime(frame.adaptation_cd_m2) == "mesopic"
    np.testing.assert_allclose(frame.adaptation_cd_m2, reference.adaptation_cd_m2[0], rtol=1e-12)
    assert np.abs(codes(frame.image) - codes(reference.frames)).max() < 0.01


def test_the_bank_prepares_both_regimes_beside_a_regime_bound():
    # the gaze's targets span 3 cd/m² (mesopic to photopic): every frame, however adapted,
    # finds its regime's entries made by prepare
    scene = np.full((32, 64, 3), 0.5)
    scene[:, 32:] = 20.0
    scene[15:17, 30:34] = 5e4
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, pupils_mm=(4.0, 5.0))
    made = live.prepare()
    low, high = made.adaptation_cd_m2
    assert low < 3.0 < high
    seen = set()
    for gaze in [(16, 0), (16, 63), (16, 0), (16, 40), (16, 20)] * 3:
        frame = live.frame(gaze_px=gaze, pupil_mm=4.5, frame_time_s=0.3)
        assert frame.new_entries == 0, (gaze, frame.adaptation_cd_m2)
        seen.add(regime(frame.adaptation_cd_m2))
    assert seen == {"mesopic", "photopic"}
    for bound in (3.0, 0.01):  # an eye adapted to either side of the bound itself
        for state in (bound, np.nextafter(bound, 0.0), np.nextafter(bound, np.inf)):
            live = LiveNight(
                scene, pixel_deg=PIXEL_DEG, pupils_mm=(4.0, 5.0), initial_adaptation_cd_m2=state
            )
            live.prepare()
            frame = live.frame(gaze_px=(16, 0), pupil_mm=4.5, frame_time_s=0.0)
            assert frame.adaptation_cd_m2 == state and frame.new_entries == 0, state


def test_a_hybrid_models_wave_pupil_follows_the_tracked_pupil():
    # the wave optics' pupil stayed the model's own (and the Vos part photopic): 267 codes
    # from render_night of the frame's pupil and regime; at a bank pupil it is that render
    from glarelab.glare import HybridGlare

    scene = np.full((24, 32, 3), 0.3)
    scene[12, 16] = 3e4
    live = LiveNight(
        scene, pixel_deg=0.2, glare_model="hybrid", initial_adaptation_cd_m2=0.5,
        pupils_mm=(3.0, 5.0),
    )  # fmt: skip
    images = {}
    for pupil in (3.0, 5.0):
        frame = live.frame(gaze_px=(12, 16), pupil_mm=pupil, frame_time_s=0.0)
        images[pupil] = frame.image.copy()
        reference = render_night(
            scene, pixel_deg=0.2, effects=("adaptation", "glare"),
            glare_model=eye(pupil, frame.adaptation_cd_m2, HybridGlare()),
            pupil_from_adaptation=False, gaze_px=(12.0, 16.0), initial_adaptation_cd_m2=0.5,
            frame_time_s=0.0, tolerance_codes=0.0,
        )  # fmt: skip
        assert np.abs(codes(frame.image) - codes(reference.frames)).max() < 0.01, pupil
    assert np.abs(codes(images[3.0]) - codes(images[5.0])).max() > 1.0
    assert pupil_bank_mm(HybridGlare(), (2.0, 4.0))[1:3].tolist() == [np.nextafter(3.0, 0), 3.0]


def test_a_bad_glare_method_is_named_as_given():
    # the error named the renderer's "composition", not the glare_method the caller gave
    with pytest.raises(ValueError, match=r"^glare_method must be one of 'Yoshida2008'"):
        LiveNight(np.full((8, 8), 0.05), pixel_deg=0.1, glare_method="bogus")


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"pupils_mm": (3.0, 50.0)}, r"^pupils_mm holds 50 mm, outside the 0.5-10 mm"),
        ({"pupils_mm": (0.2, 3.0), "glare_model": VosGlare(regime="mesopic")},
         r"^pupils_mm holds 0.2 mm, outside the 0.5-10 mm"),
        ({"pupils_mm": (0.7, 3.0), "glare_model": "wave"},
         r"^pupils_mm holds 0.7 mm, which the glare model refuses \(pupil_mm must be in \[1, 10\]"),
        ({"pupils_mm": (0.7, 3.0), "glare_model": "hybrid"},  # its wave part's pupil
         r"^pupils_mm holds 0.7 mm, which the glare model refuses \(pupil_mm must be in \[1, 10\]"),
        ({"pupils_mm": (2.0, 4.0, 6.0), "glare_model": "gaussian"},
         r"^pupils_mm=\(2.0, 4.0, 6.0\) with glare_model='gaussian': the model takes no frame's"),
    ],
)  # fmt: skip
def test_bank_pupils_the_model_would_refuse_or_ignore_are_refused(options, match):
    # pupils_mm=(3, 50) rendered frames at a 40 mm pupil, which VosGlare itself refuses
    with pytest.raises(ValueError, match=match):
        LiveNight(np.full((8, 8), 0.05), pixel_deg=0.1, **options)


def test_a_frame_reports_the_pupil_its_glare_was_rendered_for():
    # the Gaussian, which has no pupil, reported the frame's 4 mm
    scene = np.full((8, 8), 0.05)
    frame = LiveNight(scene, pixel_deg=0.1, glare_model="gaussian").frame(
        gaze_px=None, pupil_mm=4.0, frame_time_s=0.0
    )
    assert np.isnan(frame.pupil_mm)
    hybrid = LiveNight(scene, pixel_deg=0.5, glare_model="hybrid", pupils_mm=(3.0, 5.0))
    frame = hybrid.frame(gaze_px=None, pupil_mm=4.0, frame_time_s=0.0)
    assert frame.pupil_mm == 4.0  # its wave part's, set each frame
    vos = LiveNight(scene, pixel_deg=0.1).frame(gaze_px=None, pupil_mm=4.0, frame_time_s=0.0)
    assert vos.pupil_mm == 4.0


def test_an_unknown_glare_model_is_named_as_given():
    # the error named the renderer's "model", not the glare_model the caller gave
    with pytest.raises(ValueError, match=r"^glare_model must be one of 'Yoshida2008'"):
        LiveNight(np.full((8, 8), 0.05), pixel_deg=0.1, glare_model="bogus")


def test_a_refused_frame_leaves_the_held_gaze_and_pupil(scene):
    # a frame refused for its time (or its pupil) still left its gaze and pupil held for the
    # next frame without a sample
    live = LiveNight(scene, pixel_deg=PIXEL_DEG)
    live.frame(gaze_px=(5.0, 5.0), pupil_mm=5.0, frame_time_s=0.0)
    with pytest.raises(ValueError, match="frame_time_s must be a finite number >= 0 s"):
        live.frame(gaze_px=(30.0, 50.0), pupil_mm=7.0, frame_time_s=-0.01)
    with pytest.raises(ValueError, match="pupil_mm must lie within the bank"):
        live.frame(gaze_px=(30.0, 50.0), pupil_mm=9.5, frame_time_s=0.01)
    held = live.frame(gaze_px=None, pupil_mm=None, frame_time_s=0.01)
    assert (held.gaze_px, held.pupil_mm) == ((5.0, 5.0), 5.0)


@pytest.mark.parametrize("pupil", [-3.0, math.inf, "5"])
def test_a_bad_pupil_is_refused_for_a_model_without_a_frames_pupil(scene, pupil):
    # the Gaussian model accepted pupil_mm=-3 and returned it
    live = LiveNight(scene, pixel_deg=PIXEL_DEG, glare_model="gaussian")
    with pytest.raises(ValueError, match="pupil_mm must be a finite number > 0 mm"):
        live.frame(gaze_px=(5.0, 5.0), pupil_mm=pupil, frame_time_s=0.0)


def test_a_bank_of_text_names_its_argument():
    # pupil_bank_mm(model, "2,4") said "could not convert string to float: '2,4'"
    with pytest.raises(ValueError, match="pupils_mm must be at least one finite pupil"):
        pupil_bank_mm(VosGlare(), "2,4")


def test_an_infinite_initial_adaptation_is_called_not_finite():
    # it said "must be in [0, inf] cd/m², got inf"
    with pytest.raises(ValueError, match="initial_adaptation_cd_m2 must be a finite number >= 0"):
        LiveNight(np.ones((8, 8)), pixel_deg=PIXEL_DEG, initial_adaptation_cd_m2=math.inf)
