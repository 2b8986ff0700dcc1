"""The glare models' constructors and kernels at their boundary: a bad argument is refused with
a ValueError or TypeError naming it (never another exception, never a NaN kernel), and pixel
sizes across the allowed range (1e-5° to 180°) give finite kernels."""

import math
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from glarelab.glare import GaussianGlare, VosGlare, kernel
from glarelab.glare.models.hybrid import HybridGlare
from glarelab.glare.models.wave import WaveOpticsGlare

from ..strategies import NOT_A_NUMBER, NOT_FINITE_POSITIVE, SETTINGS

NOT_A_FLAG = st.one_of(st.text(max_size=4), st.integers(), st.none(), st.floats())
NOT_A_SEED = st.one_of(
    st.integers(max_value=-1),
    st.floats(allow_nan=True),
    st.booleans(),
    st.text(max_size=3),
    st.none(),
)

# argument -> (constructor, strategy of bad values)
BAD_CONSTRUCTIONS = {
    "sigma_deg": (
        GaussianGlare,
        st.one_of(
            NOT_A_NUMBER,
            NOT_FINITE_POSITIVE,
            st.floats(0.0, 9.9e-6, exclude_min=True),  # below 1e-5°, as the command line
            st.floats(90.0, 1e300, exclude_min=True),
        ),
    ),
    "sampling": (GaussianGlare, st.one_of(st.text(max_size=6), st.none(), st.integers())),
    "normalisation": (GaussianGlare, st.one_of(st.text(max_size=6), st.none())),
    "regime": (VosGlare, st.one_of(st.text(max_size=6), st.none(), st.integers())),
    "age": (
        VosGlare,
        st.one_of(
            NOT_A_NUMBER.filter(lambda v: v is not None),
            st.floats(-1e9, -1e-9),
            st.floats(100, 1e300),
        ),
    ),
    "pupil_mm": (VosGlare, st.one_of(st.booleans(), st.text(max_size=3), NOT_FINITE_POSITIVE)),
    "flare_lines": (VosGlare, NOT_A_FLAG),
    "seed": (VosGlare, NOT_A_SEED),
    "eyelashes": (WaveOpticsGlare, NOT_A_FLAG),
    "fresnel": (WaveOpticsGlare, NOT_A_FLAG),
    "particles": (
        WaveOpticsGlare,
        st.one_of(st.booleans(), st.floats(), st.integers(max_value=-1)),
    ),
}


@SETTINGS
@given(data=st.data())
def test_a_bad_constructor_argument_is_refused_naming_it(data):
    name = data.draw(st.sampled_from(sorted(BAD_CONSTRUCTIONS)), label="argument")
    constructor, bad = BAD_CONSTRUCTIONS[name]
    value = data.draw(bad, label=name)
    with pytest.raises((ValueError, TypeError)) as raised:
        constructor(**{name: value})
    assert name in str(raised.value)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("sigma_deg", [True, "0.3", np.array([0.3, 0.4])])
def test_a_sigma_that_is_not_a_number_is_refused(sigma_deg):
    # True was read as 1°, "0.3" as 0.3°
    with pytest.raises(ValueError, match=r"^sigma_deg must be a finite number > 0 deg, got"):
        GaussianGlare(sigma_deg=sigma_deg)


@pytest.mark.parametrize("flag", [VosGlare, HybridGlare])
def test_a_flag_given_as_a_word_is_refused(flag):
    with pytest.raises(ValueError, match=r"flare_lines must be True or False, got 'no'"):
        flag(flare_lines="no")  # 'no' is true to `if`: the streaks would be drawn


@pytest.mark.parametrize(
    ("sigma_deg", "match"),
    [
        (5e-324, r"sigma_deg must be a finite number > 0 deg, got 5e-324"),  # subnormal
        (1e-300, r"sigma_deg must be at least 1e-05 deg .*; got 1e-300"),
    ],
)
def test_a_tiny_sigma_is_refused_not_a_nan_kernel(sigma_deg, match):
    with pytest.raises(ValueError, match=match):
        GaussianGlare(sigma_deg=sigma_deg)


MODELS = [GaussianGlare(sigma_deg=0.1), VosGlare()]
BAD_PIXEL_DEG = st.one_of(
    NOT_A_NUMBER,
    NOT_FINITE_POSITIVE,
    st.floats(180.0, 1e300, exclude_min=True),
    st.floats(0.0, 9.9e-6),
)
BAD_SHAPE = st.one_of(
    st.tuples(st.integers(-3, 12), st.integers(-3, 12)).filter(
        lambda s: min(s) < 1 or s[0] % 2 == 0 or s[1] % 2 == 0
    ),
    st.tuples(st.floats(1.5, 9.5).filter(lambda x: x != int(x)), st.just(5)),
    st.tuples(st.booleans(), st.booleans()),
    st.tuples(st.just(5), st.just(5), st.just(5)),
    st.text(max_size=3),
    st.none(),
)


@pytest.mark.parametrize("model", MODELS, ids=["gaussian", "vos"])
@SETTINGS
@given(data=st.data())
def test_a_bad_kernel_argument_is_refused_naming_it(model, data):
    name = data.draw(st.sampled_from(["pixel_deg", "shape"]), label="argument")
    arguments = {"pixel_deg": 0.05, "shape": (9, 9)}
    arguments[name] = data.draw(BAD_PIXEL_DEG if name == "pixel_deg" else BAD_SHAPE, label=name)
    with pytest.raises((ValueError, TypeError)) as raised:
        model.kernel(arguments["pixel_deg"], arguments["shape"])
    assert name in str(raised.value)
    with pytest.raises((ValueError, TypeError)) as raised:
        kernel(model, arguments["pixel_deg"], arguments["shape"])
    assert name in str(raised.value)


@pytest.mark.filterwarnings("ignore:sigma_deg / pixel_deg")
@SETTINGS
@given(
    log_pixel_deg=st.floats(math.log10(1e-5), math.log10(180.0)),
    model=st.sampled_from(
        [
            GaussianGlare(sigma_deg=1e-5),
            GaussianGlare(sigma_deg=90.0, sampling="pixel"),
            GaussianGlare(normalisation="Yoshida2008"),
            VosGlare(),
            VosGlare(regime="mesopic", age=60.0, pupil_mm=2.0),  # no halo: any pixel
        ]
    ),
    half=st.integers(0, 7),
)
def test_kernels_are_finite_across_the_allowed_pixel_sizes(log_pixel_deg, model, half):
    pixel_deg = min(10.0**log_pixel_deg, 180.0)
    made = model.kernel(pixel_deg, (2 * half + 1, 2 * half + 1))
    assert np.isfinite(made.values).all() and (made.values >= 0).all()
    assert math.isfinite(made.energy_outside)


@pytest.mark.parametrize("pixel_deg", [1e-5, 20.0])
def test_the_halo_is_finite_at_the_ends_of_its_pixel_sizes(pixel_deg):
    made = VosGlare(regime="scotopic").kernel(pixel_deg, (3, 3))
    assert np.isfinite(made.values).all() and (made.values >= 0).all()


def test_a_pixel_too_coarse_for_the_halo_samples_is_refused_not_gigabytes():
    # 180° at 0.01° a sample: 18000² samples a pixel, 2.4 GB an array (it was killed)
    with pytest.raises(ValueError, match=r"pixel_deg must be at most 20 deg for the scotopic"):
        VosGlare(regime="scotopic").kernel(180.0, (5, 5))


@SETTINGS
@given(seed=st.integers(1, 2**32), model=st.sampled_from([VosGlare, HybridGlare]))
def test_a_seed_without_flare_lines_is_refused_not_ignored(seed, model):
    # VosGlare(seed=3) was accepted and the seed placed nothing (the command line refuses
    # --seed without --flare-lines)
    with pytest.raises(ValueError, match=rf"^seed={seed} without flare_lines=True: .* ignored"):
        model(seed=seed)
    assert model(seed=seed, flare_lines=True).seed == seed
    assert model(seed=0).seed == 0


@pytest.mark.parametrize("model", [*MODELS, "vos"], ids=["gaussian", "vos", "by-name"])
def test_a_kernel_too_large_for_the_memory_is_refused_before_allocating(model):
    # kernel('vos', 0.01, (100001, 100001)) raised MemoryError after asking for 37 GiB
    with pytest.raises(
        ValueError,
        match=r"^shape \(100001, 100001\) \(a kernel takes about 128 bytes a pixel while it "
        r"is digitised\) needs about 1192\.1 GiB of memory, [\d.]+ GiB are available",
    ):
        kernel(model, 0.01, (100001, 100001))
    if not isinstance(model, str):  # the model's own kernel method too
        with pytest.raises(ValueError, match=r"^shape \(100001, 100001\) .* GiB are available"):
            model.kernel(0.01, (100001, 100001))


@pytest.mark.parametrize("wavelength_nm", [True, "568", [500.0, "x"], [[500.0], [1.0, 2.0]]])
def test_a_wavelength_that_is_no_number_is_refused_not_kept_or_read_as_one(wavelength_nm):
    # True was read as 1.0 nm and '568' kept as a string in the model
    with pytest.raises(ValueError, match=r"^wavelength_nm must be a number or an array of numb"):
        VosGlare(wavelength_nm=wavelength_nm)


@pytest.mark.parametrize(
    ("options", "why"),
    [
        ({}, "the photopic PSF \\(eq. 5\\) has no lenticular halo"),
        ({"pupil_mm": 6.0}, "the photopic PSF \\(eq. 5\\) has no lenticular halo"),
        ({"regime": "mesopic", "pupil_mm": 2.0}, "the pupil of 2 mm drops the lenticular halo"),
        ({"regime": "scotopic", "pupil_mm": 2.9}, "the pupil of 2.9 mm drops the lenticular"),
    ],
)
@pytest.mark.parametrize(
    "halo_option",
    [
        {"wavelength_nm": 450.0},
        {"halo_spacing_deg": 0.005},
        {"flare_lines": True, "halo_lines": 10},
        {"halo_spectrum": "eleven"},
    ],
)
def test_an_option_of_the_halo_without_a_halo_is_refused(options, why, halo_option):
    """The photopic PSF (Spencer eq. 5) has no halo, and a pupil under 3 mm drops it: a
    monochromatic 450 nm kernel came back the white one, and a halo's spectrum, spacing or
    line count changed nothing, without a word."""
    from glarelab.glare.models.spectral import HaloSpectrum

    if halo_option.get("halo_spectrum") == "eleven":
        halo_option = {"halo_spectrum": HaloSpectrum(n_wavelengths=11)}
    name = next(k for k in halo_option if k != "flare_lines")
    with pytest.raises(ValueError, match=rf"^{name}=.*: it shapes only the halo, and {why}"):
        VosGlare(**options, **halo_option)
    with_halo = {**options, "regime": options.get("regime", "mesopic"), "pupil_mm": 4.0}
    VosGlare(**with_halo, **halo_option)  # acts where there is a halo


def test_an_eye_state_without_a_halo_unsets_the_halo_options():
    """The night pipeline and the live mode give each frame's model its pupil: a pupil under
    3 mm must not refuse the frame's model for the wavelength its user chose."""
    model = VosGlare(regime="mesopic", wavelength_nm=450.0, halo_spacing_deg=0.005)
    small = model.with_eye_state(pupil_mm=2.0)
    assert (small.wavelength_nm, small.halo_spacing_deg) == (None, VosGlare().halo_spacing_deg)
    assert model.with_eye_state(pupil_mm=5.0) == VosGlare(
        regime="mesopic", wavelength_nm=450.0, halo_spacing_deg=0.005, pupil_mm=5.0
    )


def test_a_wavelength_beside_a_halo_spectrum_is_refused():
    """The monochromatic halo used no spectrum: the one given was ignored."""
    from glarelab.glare.models.spectral import HaloSpectrum

    with pytest.raises(
        ValueError, match=r"^wavelength_nm=500\.0 with halo_spectrum=.*n_wavelengths=11"
    ):
        VosGlare(regime="mesopic", wavelength_nm=500.0,
                 halo_spectrum=HaloSpectrum(n_wavelengths=11))  # fmt: skip


def test_a_colour_flag_given_as_a_word_is_refused():
    # 'no' is true to `if`: it gave a colour kernel
    from glarelab.glare import digitise_kernel

    with pytest.raises(ValueError, match=r"^colour must be True or False, got 'no'$"):
        digitise_kernel("vos", 0.05, (5, 5), colour="no", cache=False)


def test_an_obstacle_image_that_passes_no_light_is_refused_not_a_kernel_of_nothing():
    with pytest.raises(ValueError, match=r"^obstacle_image is 0 \(opaque\) everywhere"):
        WaveOpticsGlare(obstacle_image=np.zeros((64, 64)), obstacle_spacing_mm=0.1)
    opaque_centre = np.ones((64, 64))
    opaque_centre[16:48, 16:48] = 0.0  # 16 mm of it opaque: the whole pupil is covered
    model = WaveOpticsGlare(obstacle_image=opaque_centre, obstacle_spacing_mm=0.5)
    with pytest.raises(ValueError, match=r"^the aperture passes no light: .* opaque over the wh"):
        kernel(model, 0.05, (31, 31))


@pytest.mark.parametrize(
    ("options", "name"),
    [
        ({"obstacle_spacing_mm": 0.01}, "obstacle_spacing_mm"),
        ({"eyelashes": False, "eyelash_count": 10}, "eyelash_count"),
        ({"eyelashes": False, "eyelash_thickness_mm": 0.2}, "eyelash_thickness_mm"),
        ({"eyelashes": False, "eyelash_curvature": 1.0}, "eyelash_curvature"),
        ({"eyelashes": False, "eye": "left"}, "eye"),
        ({"particles": 0, "particle_size_mm": 0.1}, "particle_size_mm"),
        ({"fresnel_distance_mm": 30.0}, "fresnel_distance_mm"),
        ({"diaphragm_rotation_deg": 30.0}, "diaphragm_rotation_deg"),
        ({"seed": 5, "eyelashes": False, "particles": 0}, "seed"),
        ({"eyelashes": False, "eyelid": False, "source_x_deg": 10.0}, "source_x_deg"),
        ({"eyelashes": False, "eyelid": False, "obstacle_distance_mm": 5.0},
         "obstacle_distance_mm"),
        ({"field_luminance_cd_m2": 0.001}, "field_luminance_cd_m2"),  # the pupil is given
    ],
)  # fmt: skip
def test_a_wave_option_that_shapes_nothing_drawn_is_refused(options, name):
    """Each was accepted and the kernel was the default's, its description claiming it."""
    with pytest.raises(ValueError, match=f"^{name}=.* has no effect"):
        WaveOpticsGlare(pupil_mm=3.0, **options)


@pytest.mark.parametrize(
    "options",
    [
        {"seed": 5},
        {"eyelashes": False, "seed": 5},  # the particles are still drawn
        {"fresnel": True, "fresnel_distance_mm": 30.0},
        {"diaphragm_sides": 6, "diaphragm_rotation_deg": 30.0},
        {"eyelashes": True, "eyelash_count": 10, "eye": "left"},
        {"particles": 10, "particle_size_mm": 0.1},
        {"eyelashes": False, "source_x_deg": 10.0},  # the lid is still moved
        {"eyelid": False, "obstacle_distance_mm": 5.0, "source_x_deg": 10.0},
    ],
)
def test_the_same_options_with_what_they_shape_are_taken(options):
    model = WaveOpticsGlare(pupil_mm=3.0, **options)
    assert all(getattr(model, key) == value for key, value in options.items())


def test_a_source_angle_of_an_eye_without_lashes_and_lid_keeps_its_kernel():
    """``at_source`` (``kernel_set``) of such an eye was refused once its angle was; it is the
    same eye, and the same kernel, at every angle."""
    bare = WaveOpticsGlare(pupil_mm=3.0, eyelashes=False, eyelid=False, particles=0)
    assert bare.at_source(20.0) is bare
    with pytest.raises(ValueError, match="source_x_deg"):
        bare.at_source(90.0)
    lid = WaveOpticsGlare(pupil_mm=3.0, eyelashes=False, particles=0)
    assert lid.at_source(20.0).source_x_deg == 20.0


@pytest.mark.parametrize("wavelength_nm", [[500.0, 600.0], np.array([568.0])])
def test_the_psf_of_many_wavelengths_at_once_is_refused_by_name(wavelength_nm):
    """It ended in numpy's 'only length-1 arrays can be converted to Python scalars'."""
    from glarelab.glare.models import vos

    with pytest.raises(ValueError, match=r"^wavelength_nm must be one wavelength \(a number\)"):
        vos.psf(1.0, "mesopic", wavelength_nm=wavelength_nm)


@pytest.mark.parametrize("name", ["corona_lines", "halo_lines"])
def test_a_count_of_flare_lines_without_flare_lines_is_refused(name):
    """``VosGlare(corona_lines=10)`` was taken, and no line drawn."""
    with pytest.raises(ValueError, match=rf"^{name}=10 without flare_lines=True"):
        VosGlare(**{name: 10})
    assert getattr(VosGlare(regime="mesopic", flare_lines=True, **{name: 10}), name) == 10


@pytest.mark.parametrize("regime", ["mesopic", "scotopic"])
@pytest.mark.parametrize("colour", [True, False])
def test_spencers_renormalisation_of_a_halo_the_kernel_barely_holds_is_refused(regime, colour):
    """A 21 × 21 kernel at 0.05° holds none of the green halo and 1e-21 of the red and blue
    (their rings' numerical tails): renormalised to sum to one, green was NaN, and red and blue
    were those tails multiplied into the whole halo; at 61 px red held 0.04 % of its halo."""
    model = VosGlare(regime=regime, normalisation="Spencer1995")
    for n in (21, 61):
        with pytest.raises(ValueError, match=r"holds under 1 % of the .* halo of a channel") as e:
            model.kernel(0.05, (n, n), colour=colour)
    across = int(re.search(r"at least (\d+) px across", str(e.value))[1])
    with pytest.raises(ValueError, match=r"holds under 1 %"):  # the least size: 2 px less is
        model.kernel(0.05, (across - 2, across - 2), colour=colour)  # refused (it named 95 px
    k = model.kernel(0.05, (across, across), colour=colour)  # where 77 px was accepted)
    assert np.isfinite(k.values).all() and (k.values >= 0).all()
    np.testing.assert_allclose(k.values.sum(axis=(0, 1)), 1.0, rtol=1e-9)
    np.testing.assert_allclose(k.energy_outside, 0.0, atol=1e-12)
    psf = VosGlare(regime=regime).kernel(0.05, (21, 21), colour=colour)  # no renormalisation
    np.testing.assert_allclose(psf.values.sum(axis=(0, 1)) + psf.energy_outside, 1.0, rtol=1e-9)


@pytest.mark.parametrize("name", ["corona_lines", "halo_lines"])
def test_a_count_of_flare_lines_beyond_memory_is_refused_when_the_model_is_made(name):
    """``corona_lines=10**9`` was taken, and the kernel then took all memory (MemoryError or
    the process killed)."""
    from glarelab.glare.models.flare import MAX_FLARE_LINES, flare_line_pattern

    with pytest.raises(
        ValueError, match=rf"^{name} must be at most 1,000,000 .*got 1,000,000,000"
    ):
        VosGlare(regime="mesopic", flare_lines=True, **{name: 10**9})
    VosGlare(regime="mesopic", flare_lines=True, **{name: MAX_FLARE_LINES})
    with pytest.raises(ValueError, match=r"^n_lines must be at most 1,000,000"):
        flare_line_pattern((11, 11), rng=np.random.default_rng(0), n_lines=MAX_FLARE_LINES + 1)


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"regime": "mesopic", "wavelength_nm": np.array([500.0, 600.0])},
         r"^wavelength_nm must be one number \(380-780 nm\) or None; got array"),
        ({"samples_per_pixel": 10**12}, r"^samples_per_pixel must be at most 2000"),
        ({"center_samples_per_pixel": 10**9}, r"^center_samples_per_pixel must be at most 2000"),
    ],
)  # fmt: skip
def test_a_vos_option_no_kernel_can_be_made_of_is_refused_when_the_model_is_made(options, match):
    """An array of wavelengths failed inside the digitiser ('operands could not be broadcast'),
    10**12 samples a pixel asked numpy for 2 TiB: both after the model was taken."""
    with pytest.raises(ValueError, match=match):
        VosGlare(**options)


def test_the_volume_of_a_name_is_refused_naming_the_profile():
    from glarelab.glare.models import vos

    with pytest.raises(ValueError, match=r"^profile must be a function of angles in degrees"):
        vos.volume("f2")


def test_check_kernel_refuses_what_kernel_refuses_for_the_halos_sampling():
    """``protocol check`` said valid for halo_spacing_deg = 1e-5 and the build then refused
    the pixels (2000² samples a pixel at most)."""
    model = VosGlare(regime="mesopic", halo_spacing_deg=1e-5)
    with pytest.raises(ValueError, match=r"^pixel_deg must be at most 0.02 deg") as checked:
        model.check_kernel(0.05, (101, 101))
    with pytest.raises(ValueError) as made:
        model.kernel(0.05, (101, 101))
    assert str(made.value) == str(checked.value)
    model.check_kernel(0.01, (101, 101))


def test_a_pupil_of_the_photopic_psf_is_refused_and_each_frames_eye_state_leaves_it_unset():
    """VosGlare(pupil_mm=2) gave the photopic kernel without the pupil (it has no halo to
    drop), without a word; the command line refused --pupil-mm there."""
    with pytest.raises(ValueError, match=r"^pupil_mm=2 with regime='photopic': .* ignored"):
        VosGlare(pupil_mm=2)
    assert VosGlare().with_eye_state(pupil_mm=2.0).pupil_mm is None
    mesopic = VosGlare(regime="mesopic", pupil_mm=5.0)
    assert mesopic.with_eye_state(pupil_mm=2.0, regime="photopic") == VosGlare()
    assert VosGlare().with_eye_state(pupil_mm=2.0, regime="mesopic").pupil_mm == 2.0
    # the hybrid model's Vos part takes the wave part's pupil only where it has a halo
    wave = WaveOpticsGlare(pupil_mm=2.0, eyelashes=False, eyelid=False, particles=0)
    made = HybridGlare(wave=wave).kernel(0.05, (11, 11))
    assert made.description["pupil_mm"] is None and np.isfinite(made.values).all()
    assert HybridGlare(wave=wave, regime="mesopic")._vos().halo_skipped
