"""The night pipeline: glare and night vision in Luidolt's order (Fig. 4.1), each effect on and
off, any glare model, sequences, and the numerical extremes."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab import glare
from glarelab.glare import night
from glarelab.glare.models import eye
from glarelab.glare.night import acuity, adaptation, scotopic
from glarelab.glare.night.live import LiveNight

PIXEL = 0.05


def street(height=24, width=36, *, lamp=5e4, ambient=0.02):
    rng = np.random.default_rng(7)
    scene = ambient * rng.uniform(0.3, 1.5, (height, width, 1)) * np.array([1.0, 0.5, 0.3])
    scene[10:12, 16:18] = lamp
    return scene


def test_without_effects_the_scene_is_exposed_and_clipped_by_the_display():
    scene = street()
    out = night.render_night(scene, pixel_deg=PIXEL, effects=(), adapted_display_cd_m2=10.0)
    target = adaptation.frame_luminance(scene, pixel_deg=PIXEL)
    assert_allclose(out.adaptation_cd_m2, [target])
    assert_allclose(out.exposure, [10.0 / target])
    assert_allclose(out.frames, np.minimum(scene * 10.0 / target, 100.0), rtol=1e-12)
    assert math.isnan(out.pupil_mm[0]) and out.models == [None]


def test_the_pipeline_is_the_effects_in_luidolts_order():
    # adaptation → exposure → glare (L_dmax clamp) → acuity (σ of the scene) → scotopic (σ(L_i))
    scene = street()
    out = night.render_night(scene, pixel_deg=PIXEL, glare_model=glare.GaussianGlare())
    level = out.adaptation_cd_m2[0]
    exposed = scene * out.exposure[0]
    model = night.adapted_model(glare.GaussianGlare(), level)
    glared = (
        glare.GlareRenderer(model, pixel_deg=PIXEL, shape=scene.shape[:2], l_dmax_cd_m2=100.0)
        .render(exposed)
        .image
    )
    blurred = acuity.acuity_blur(
        np.minimum(glared, 100.0), pixel_deg=PIXEL, white_cd_m2=100.0,
        luminance_scale=1 / out.exposure[0],
    )  # fmt: skip
    coloured = scotopic.scotopic_shift_Luidolt2020(blurred, level)
    assert_allclose(out.frames, np.clip(coloured, 0, 100.0), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("effect", night.EFFECTS)
def test_each_effect_changes_the_image_and_only_when_on(effect):
    scene = street(lamp=300.0, ambient=0.002)  # a faint glow: the dark street stays dark
    sequence = [scene, scene]  # adaptation needs time to show
    others = tuple(e for e in night.EFFECTS if e != effect)
    options = {"pixel_deg": PIXEL, "frame_time_s": 0.2, "initial_adaptation_cd_m2": 0.1}
    with_it = night.render_night(sequence, **options)
    if effect == "adaptation":  # its options would be ignored without it, and are refused
        options = {"pixel_deg": PIXEL}
    without = night.render_night(sequence, effects=others, **options)
    assert not np.allclose(with_it.frames[1], without.frames[1], rtol=1e-3, atol=1e-6)


def test_adaptation_follows_eq_5_2_over_the_sequence():
    frames = [street(ambient=0.02)] * 6
    out = night.render_night(
        frames, pixel_deg=PIXEL, frame_time_s=0.1, initial_adaptation_cd_m2=20.0,
        effects=("adaptation",),
    )  # fmt: skip
    expected = adaptation.adaptation_luminance(out.targets_cd_m2, 0.1, initial_cd_m2=20.0)
    assert_allclose(out.adaptation_cd_m2, expected)
    assert (np.diff(out.adaptation_cd_m2) < 0).all()  # darkening towards the street
    # the display brightens as the eye adapts: the same scene, more exposure each frame
    means = [f.mean() for f in out.frames]
    assert (np.diff(means) > 0).all()


def test_without_adaptation_the_eye_is_adapted_at_once():
    frames = [street(ambient=0.02), street(ambient=2.0)]
    out = night.render_night(frames, pixel_deg=PIXEL, effects=("glare",))
    assert_allclose(out.adaptation_cd_m2, out.targets_cd_m2)


def test_the_pupil_and_regime_come_from_the_adapted_luminance():
    scene = street()
    out = night.render_night(scene, pixel_deg=PIXEL, effects=("glare",))
    level = out.adaptation_cd_m2[0]
    assert out.pupil_mm[0] == pytest.approx(round(eye.pupil_diameter_mm(level), 1))
    assert out.models[0].regime == eye.regime(level)
    fixed = night.render_night(
        scene, pixel_deg=PIXEL, effects=("glare",), pupil_from_adaptation=False
    )
    assert fixed.models[0] == glare.VosGlare()


def test_looking_at_the_lamp_raises_the_adaptation():
    scene = street()
    window = {"pixel_deg": PIXEL, "effects": (), "window_sigma_deg": 0.2}
    away = night.render_night(scene, gaze_px=(2, 2), **window)
    at = night.render_night(scene, gaze_px=(11, 17), **window)
    assert at.targets_cd_m2[0] > away.targets_cd_m2[0]
    per_frame = night.render_night([scene, scene], gaze_px=[(2, 2), (11, 17)], **window)
    assert_allclose(per_frame.targets_cd_m2, [away.targets_cd_m2[0], at.targets_cd_m2[0]])


@pytest.mark.parametrize(
    "model",
    [
        glare.GaussianGlare(sigma_deg=0.1),
        glare.VosGlare(),
        glare.WaveOpticsGlare(eyelashes=False, eyelid=False, particles=20, psf_extent_deg=2.0),
        glare.HybridGlare(
            glare.WaveOpticsGlare(eyelashes=False, eyelid=False, particles=0, psf_extent_deg=2.0)
        ),
    ],
    ids=["gaussian", "vos", "wave", "hybrid"],
)
def test_any_glare_model_takes_its_pupil_from_the_adaptation(model):
    out = night.render_night(street(), pixel_deg=PIXEL, glare_model=model)
    frame = out.frames
    assert np.isfinite(frame).all() and (frame >= 0).all() and (frame <= 100.0).all()
    used = out.models[0]
    pupil = round(eye.pupil_diameter_mm(out.adaptation_cd_m2[0]), 1)
    if hasattr(model, "pupil_mm"):
        assert used.pupil_mm == pytest.approx(pupil)
    if hasattr(model, "wave"):
        assert used.wave.pupil_mm == pytest.approx(pupil)


def test_adapted_model_leaves_a_model_without_an_eye_alone():
    gaussian = glare.GaussianGlare()
    assert night.adapted_model(gaussian, 0.01) is gaussian
    vos = night.adapted_model(glare.VosGlare(flare_lines=True, seed=3), 1e-4)
    assert (vos.regime, vos.flare_lines, vos.seed) == ("scotopic", True, 3)


def test_an_eye_whose_pupil_a_field_luminance_set_is_adapted_to_the_pupil_alone():
    """The pupil the adaptation gives replaces the one the model's field luminance set (a
    model with both is refused: the luminance would act on nothing)."""
    wave = glare.WaveOpticsGlare(field_luminance_cd_m2=0.01, particles=0)
    used = night.adapted_model(wave, 100.0)
    assert used.pupil_mm == pytest.approx(glare.pupil_diameter_mm(100.0), abs=0.05)
    assert used.field_luminance_cd_m2 == glare.WaveOpticsGlare().field_luminance_cd_m2
    # given to the live mode or the pipeline, whose frames set the pupil, it is refused (the
    # frames were the same for 0.001 and 1000 cd/m²); a model without it runs
    live = LiveNight(np.full((8, 10, 3), 0.5), pixel_deg=0.1, pupils_mm=(3.0, 5.0),
                     glare_model=glare.WaveOpticsGlare(particles=0))  # fmt: skip
    frame = live.frame(gaze_px=(4.0, 5.0), pupil_mm=5.0, frame_time_s=1 / 60)
    assert frame.pupil_mm == 5.0 and np.isfinite(frame.image).all()


@pytest.mark.parametrize("frames", [1, 3])
def test_black_frames(frames):
    out = night.render_night(
        [np.zeros((5, 6, 3))] * frames, pixel_deg=PIXEL, frame_time_s=1 / 60,
        initial_adaptation_cd_m2=100.0,
    )  # fmt: skip
    assert_allclose(np.array(out.frames), 0.0, atol=0)
    assert (out.adaptation_cd_m2 > 0).all() and np.isfinite(out.exposure).all()


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    height=st.integers(1, 7),
    width=st.integers(1, 9),
    exponents=st.lists(st.floats(-8.0, 9.0), min_size=63 * 3, max_size=63 * 3),
    black=st.floats(0.0, 1.0),
    frames=st.integers(1, 3),
    effects=st.lists(st.sampled_from(night.EFFECTS), unique=True, max_size=4),
    scotopic_method=st.sampled_from(scotopic.METHODS),
)
def test_no_nan_and_no_negative_light_from_0_to_1e9_cd_m2(
    height, width, exponents, black, frames, effects, scotopic_method
):
    values = 10.0 ** np.array(exponents[: height * width * 3]).reshape(height, width, 3)
    values[values < 10.0 ** (-8 + 17 * black)] = 0.0  # true black pixels, up to all of them
    values[0, 0] = 1e9 if values.size > 3 else values[0, 0]
    options = {  # each only with its effect (refused without it, which would ignore it)
        "frame_time_s": 1 / 60 if "adaptation" in effects and frames > 1 else None,
        "glare_model": glare.GaussianGlare(sigma_deg=0.2) if "glare" in effects else None,
        "scotopic_method": scotopic_method if "scotopic" in effects else "Luidolt2020",
    }
    out = night.render_night([values] * frames, pixel_deg=0.1, effects=effects, **options)
    for frame in out.frames:
        assert np.isfinite(frame).all() and (frame >= 0).all() and (frame <= 100.0).all()
    assert np.isfinite(out.adaptation_cd_m2).all() and (out.adaptation_cd_m2 >= 0).all()


def test_a_luminance_image_is_shown_as_grey_rgb():
    scene = street()[..., 1]
    out = night.render_night(scene, pixel_deg=PIXEL, effects=("acuity",))
    assert out.frames.shape == (*scene.shape, 3)
    assert_allclose(out.frames[..., 0], out.frames[..., 2], rtol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"scene_cd_m2": []}, "at least one frame"),
        ({"scene_cd_m2": [np.ones((3, 3)), np.ones((3, 4))]}, "one shape"),
        ({"scene_cd_m2": "street"}, "scene_cd_m2"),
        ({"scene_cd_m2": -np.ones((3, 3))}, "scene_cd_m2"),
        ({"effects": ("bloom",)}, "effects"),
        ({"pixel_deg": 0.0}, "pixel_deg"),
        ({"display_max_cd_m2": -1.0}, "display_max_cd_m2"),
        ({"adapted_display_cd_m2": 200.0}, "adapted_display_cd_m2"),
        ({"scene_cd_m2": [np.ones((3, 3))] * 2}, "frame_time_s"),
        (
            {"scene_cd_m2": [np.ones((3, 3))] * 2, "frame_time_s": 0.1, "gaze_px": [(1, 1)]},
            "gaze_px",
        ),
        ({"acuity_method": "Ferwerda"}, "acuity_method"),
        ({"scotopic_method": "Krawczyk"}, "scotopic_method"),
        ({"glare_model": "bloom"}, "model"),
    ],
)
def test_bad_input_is_refused_by_name(kwargs, pattern):
    arguments = {"scene_cd_m2": np.ones((3, 3)), "pixel_deg": 0.1} | kwargs
    with pytest.raises(ValueError, match=pattern):
        night.render_night(arguments.pop("scene_cd_m2"), **arguments)


def test_a_sequence_with_the_gaze_falloff_renders_each_frame_as_alone():
    """The falloff's unglared frame once took the glare model's name, and the second frame of
    every sequence ended in a TypeError."""
    first = np.full((32, 32), 0.05)
    first[16, 16] = 500.0
    second = np.roll(first, 5, axis=1)
    options = {"pixel_deg": 0.05, "effects": ("glare",), "gaze_px": (16, 16)}
    both = glare.render_night([first, second], glare_falloff_deg=1.0, **options).frames
    for frame, alone in zip(both, (first, second), strict=True):
        expected = glare.render_night(alone, glare_falloff_deg=1.0, **options).frames
        np.testing.assert_allclose(frame, expected.reshape(frame.shape), rtol=1e-12, atol=0)


def test_a_gaze_of_true_is_refused_not_read_as_row_1():
    with pytest.raises(ValueError, match="gaze_px"):
        glare.render_night(np.full((16, 16), 0.05), pixel_deg=0.05, gaze_px=(True, 5))


def test_a_monochromatic_halo_adapted_to_daylight_drops_its_wavelength():
    """The photopic PSF refuses a wavelength (it has no halo to colour); a frame adapted to
    daylight makes a mesopic 500 nm model photopic, and must not be refused for it."""
    model = glare.VosGlare(regime="mesopic", wavelength_nm=500.0)
    bright = night.adapted_model(model, 100.0)
    assert (bright.regime, bright.wavelength_nm) == ("photopic", None)
    dim = night.adapted_model(model, 0.05)
    assert (dim.regime, dim.wavelength_nm) == ("mesopic", 500.0)


def test_a_models_own_pupil_the_adaptation_would_replace_is_refused():
    """``render_night(glare_model=VosGlare(regime='mesopic', pupil_mm=2))`` replaced the
    pupil by each frame's: 2 mm and 8 mm gave the same frames, without a word."""
    scene = np.full((32, 32, 3), 0.05)
    scene[16, 16] = 500.0
    for model, own in (
        (glare.VosGlare(regime="mesopic", pupil_mm=2.0), "pupil_mm=2.0"),
        (glare.HybridGlare(wave=glare.WaveOpticsGlare(pupil_mm=4.0)), "pupil_mm=4.0"),
        (glare.WaveOpticsGlare(field_luminance_cd_m2=1000.0), "field_luminance_cd_m2=1000.0"),
    ):
        with pytest.raises(ValueError, match=rf"^glare_model has {own}, which "
                           "pupil_from_adaptation=True replaces"):  # fmt: skip
            night.render_night(scene, pixel_deg=0.1, glare_model=model)
        if isinstance(model, glare.HybridGlare):
            continue  # the live mode sets the pupil of a model with one of its own alone
        with pytest.raises(ValueError, match=rf"^glare_model has {own}, which each frame's "
                           "pupil \\(from the eye tracker\\) replaces"):  # fmt: skip
            LiveNight(scene, pixel_deg=0.1, glare_model=model)
    kept = [
        night.render_night(scene, pixel_deg=0.1, pupil_from_adaptation=False,
                           glare_model=glare.VosGlare(regime="mesopic", pupil_mm=p)).frames
        for p in (2.0, 8.0)
    ]  # fmt: skip
    assert np.abs(kept[0] - kept[1]).max() > 0  # the pupil acts where it is kept


def test_a_scene_beyond_what_a_frame_holds_is_refused_by_its_own_name():
    """A 1e28 cd/m² scene was refused as 'luminance_cd_m2 reaches 9.83e+30' (the frame after
    the adaptation's exposure): another argument's name, another value."""
    scene = np.full((8, 8, 3), 1e-3)
    scene[4, 4] = 1e28
    with pytest.raises(ValueError, match=r"^scene_cd_m2 reaches 1e\+28 cd/m², beyond the 1e\+20"):
        night.render_night(scene, pixel_deg=0.1)
    with pytest.raises(ValueError, match=r"^scene_cd_m2\[1\] reaches 1e\+28 cd/m²"):
        night.render_night([scene * 0 + 1.0, scene], pixel_deg=0.1, frame_time_s=0.1)


def test_a_frame_adapted_to_daylight_unsets_the_options_of_the_halo():
    """adapted_model gives a daylight frame the photopic PSF, which has no halo: the halo's
    options the user chose are unset for that frame, not refused, and kept for a dim one."""
    model = glare.VosGlare(regime="mesopic", halo_spacing_deg=0.005, flare_lines=True,
                           halo_lines=200)  # fmt: skip
    bright = night.adapted_model(model, 100.0)
    assert (
        bright.regime == "photopic"
        and bright.halo_spacing_deg == glare.VosGlare().halo_spacing_deg
    )
    assert bright.halo_lines == glare.VosGlare().halo_lines
    dim = night.adapted_model(model, 0.05)
    assert (dim.halo_spacing_deg, dim.halo_lines) == (0.005, 200)
