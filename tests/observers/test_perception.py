"""The image-computable brightness model and the observers' noise (glarelab.observers),
and the Luidolt rating defaults: the acceptance properties of issue 14 item 5 as tests."""

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import stats as sps

from glarelab import glare
from glarelab.analysis.stats import rm_anova
from glarelab.observers.brightness import GLOW_GAIN, BrightnessModel, Percept
from glarelab.observers.noise import Observer, ObserverNoise
from glarelab.stimuli.sky import cloudy_sky

MODEL = BrightnessModel()
L_DMAX = 220.0  # Yoshida 2008 §3


def disk_image(
    disk_cd_m2: float,
    background,
    *,
    size: int = 161,
    pixel_deg: float = 0.01,
    diameter_deg: float = 0.3,
    centre: tuple[float, float] | None = None,
):
    """A disk with an antialiased edge (16 samples per pixel) on ``background`` (a number or
    an image); returns the image and the disk's coverage."""
    centre = centre if centre is not None else ((size - 1) / 2, (size - 1) / 2)
    k = 4
    offsets = (np.arange(size * k) + 0.5) / k - 0.5
    inside = (
        np.hypot(offsets[:, None] - centre[0], offsets[None, :] - centre[1]) * pixel_deg
        <= diameter_deg / 2
    )
    coverage = inside.reshape(size, k, size, k).mean(axis=(1, 3))
    return background * (1 - coverage) + disk_cd_m2 * coverage, coverage


def look(image, *, centre=(80, 80), diameter_deg=0.3, pixel_deg=0.01) -> Percept:
    return MODEL.percept(image, centre_px=centre, diameter_deg=diameter_deg, pixel_deg=pixel_deg)


def with_glare(model, disk_cd_m2, background=150.0, *, pixel_deg=0.01, size=161):
    scene, _ = disk_image(disk_cd_m2, background, size=size, pixel_deg=pixel_deg)
    return glare.render_glare(scene, model, pixel_deg=pixel_deg, l_dmax_cd_m2=L_DMAX).image


# --- a glare-free disk looks as bright as it is ----------------------------------------------


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    disk=st.floats(-2.0, 9.0).map(lambda e: 10.0**e),
    contrast=st.one_of(st.floats(0.0, 0.95), st.floats(1.05, 20.0)),
    diameter_deg=st.floats(0.05, 1.0),
    pixels_across=st.floats(4.0, 40.0),
    offset=st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 1.0)),
)
def test_a_glare_free_disk_looks_as_bright_as_it_is(
    disk, contrast, diameter_deg, pixels_across, offset
):
    """On a uniform background (black to 20 × brighter than the disk, a visible edge of at
    least 5 % contrast), at any luminance, size and pixel size, and with the centre anywhere
    within a pixel: no glow, no ring, the nominal size (within a pixel), and the disk's own
    luminance (within 0.1 %; 1 % for disks under 10 pixels across, whose border is located to
    a pixel)."""
    pixel_deg = diameter_deg / pixels_across
    size = int(2 * (diameter_deg / 2 + 0.35) / pixel_deg) + 3
    centre = ((size - 1) / 2 + offset[0] - 0.5, (size - 1) / 2 + offset[1] - 0.5)
    image, _ = disk_image(
        disk,
        disk * contrast,
        size=size,
        pixel_deg=pixel_deg,
        diameter_deg=diameter_deg,
        centre=centre,
    )
    p = MODEL.percept(image, centre_px=centre, diameter_deg=diameter_deg, pixel_deg=pixel_deg)
    assert p.glow < 1e-9 and p.ring < 1e-9  # zero but for rounding
    assert_allclose(p.disk_cd_m2, disk, rtol=1e-9)
    assert_allclose(p.apparent_diameter_deg, diameter_deg, rtol=0.02, atol=pixel_deg)
    assert_allclose(p.brightness_cd_m2, disk, rtol=1e-3 if pixels_across >= 10 else 1e-2)


def test_texture_is_not_glow():
    """On random cloudy skies like the Yoshida stimuli's (15 % contrast), a glare-free disk at
    150-433 cd/m² shows no glow in at least 80 % of skies, and its median brightness is its
    own luminance. (A bright cloud around the disk on most sides can look like a glow: the
    rest, see docs/observers.md.)"""
    pixel_deg, size = 0.0118, 271
    boosts = []
    for seed in range(12):
        sky = cloudy_sky(
            (size, size),
            pixel_deg=pixel_deg,
            rng=np.random.default_rng(seed),
            mean_cd_m2=150.0,
            contrast=0.15,
            cloud_min_deg=0.05,
            cloud_max_deg=3.2,
            slope=1.0,
            ceiling_cd_m2=0.98 * L_DMAX,
        )
        for disk in (150.0, 220.0, 433.0):
            image, _ = disk_image(disk, sky, size=size, pixel_deg=pixel_deg)
            boosts.append(look(image, centre=(135, 135), pixel_deg=pixel_deg).boost)
    boosts = np.array(boosts)
    assert np.median(np.abs(boosts)) < 1e-3
    assert np.mean(np.abs(boosts) < 0.01) >= 0.8


# --- levels at or below L_dmax give no boost; more glare, a larger boost ---------------------


@pytest.mark.parametrize(
    "model", [glare.GaussianGlare(sigma_deg=0.34), glare.VosGlare()], ids=["gaussian", "vos"]
)
@pytest.mark.parametrize("disk", [100.0, 219.0, L_DMAX])
def test_levels_at_or_below_l_dmax_give_no_boost(model, disk):
    """Nothing above L_dmax: the rendered image is the glare-free one (Yoshida eq. 1), and the
    disk looks exactly as bright as a glare-free target of the same luminance."""
    reference = with_glare(model, disk)
    target, _ = disk_image(disk, 150.0)
    assert_allclose(reference, target, rtol=0, atol=1e-9)
    assert look(reference) == look(target)
    assert_allclose(look(reference).brightness_cd_m2, disk, rtol=1e-3)


@pytest.mark.parametrize(
    ("model", "levels"),
    [
        (glare.GaussianGlare(sigma_deg=0.34), (400.0, 1000.0, 2000.0, 4000.0)),
        (glare.VosGlare(), (400.0, 1000.0, 2000.0, 8000.0)),
    ],
    ids=["gaussian", "vos"],
)
def test_a_higher_level_gives_a_larger_boost_that_saturates(model, levels):
    """More light above L_dmax, more glow in the image, a larger boost; never above the
    saturation (1 + β) (2 R_e / d)^α - 1."""
    percepts = [look(with_glare(model, level)) for level in levels]
    boosts = [p.boost for p in percepts]
    assert all(b > 0 for b in boosts)
    assert np.all(np.diff(boosts) > 0), boosts
    for p in percepts:
        ceiling = (1 + GLOW_GAIN) * (p.apparent_diameter_deg / 0.3) ** MODEL.size_exponent - 1
        assert p.boost <= ceiling + 1e-12


@settings(max_examples=40, deadline=None)
@given(amplitudes=st.lists(st.floats(0.0, 0.3), min_size=2, max_size=2, unique=True))
def test_a_stronger_glow_in_the_image_gives_a_larger_boost(amplitudes):
    """A smooth glow of relative amplitude ``a`` around a disk at 220 cd/m² on 150 cd/m² (an
    exponential ramp): the boost never falls as ``a`` grows. (Up to ``a`` = 0.3 the ramp stays
    below the disk's luminance; beyond, clamping widens the plateau and flattens the visible
    ramp, and the boost levels off: docs/observers.md.)"""
    low, high = sorted(amplitudes)
    y, x = np.indices((161, 161))
    ramp = np.exp(-np.clip(np.hypot(y - 80, x - 80) * 0.01 - 0.15, 0, None) / 0.15)

    def boost(a):
        plain, coverage = disk_image(L_DMAX, 150.0)
        image = np.minimum(plain + (1 - coverage) * a * L_DMAX * ramp, L_DMAX)
        return look(image).boost

    assert boost(high) >= boost(low) - 1e-12


def test_spencer_strong_glare_looks_brighter_than_the_75_percent_line():
    """Spencer 1995 §4: a small source whose glare peaks at 75 % of the display's maximum.
    With strong glare it looks brighter than the disc-and-annulus comparison shown at 75 %
    (Figure 13 rises above the 75 % line); with almost none, not."""
    size, pixel_deg, maximum = 151, 0.0266, 100.0
    peak = 0.75 * maximum
    source, _ = disk_image(1.0, 0.0, size=size, pixel_deg=pixel_deg, diameter_deg=4 * pixel_deg)
    disc = source
    annulus, _ = disk_image(1.0, 0.0, size=size, pixel_deg=pixel_deg, diameter_deg=10 * pixel_deg)
    annulus = annulus - disc
    geometry = {"centre_px": (75, 75), "diameter_deg": 4 * pixel_deg, "pixel_deg": pixel_deg}

    def glare_image(strength):
        scene = source * peak * (1 + strength)
        return glare.render_glare(
            scene, glare.VosGlare(), pixel_deg=pixel_deg, l_dmax_cd_m2=peak
        ).image

    comparison = MODEL.percept(peak * (disc + annulus / 3), **geometry)
    strong = MODEL.percept(glare_image(284.0), **geometry)
    weak = MODEL.percept(glare_image(0.01), **geometry)
    assert strong.brightness_cd_m2 > comparison.brightness_cd_m2
    assert weak.brightness_cd_m2 < comparison.brightness_cd_m2


# --- same image, same percept ----------------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    scale=st.floats(-3.0, 6.0).map(lambda e: 10.0**e),
)
def test_identical_images_give_identical_percepts_at_any_luminance_scale(seed, scale):
    """Any image (random, with a bright blob): the same pixels give the same percept (copies,
    float32 or float64); scaling every luminance by ``k`` scales the brightness by ``k`` and
    leaves glow, ring and size unchanged (Weber behaviour)."""
    rng = np.random.default_rng(seed)
    y, x = np.indices((81, 81))
    image = rng.gamma(2.0, 50.0, (81, 81)) + 400 * np.exp(-np.hypot(y - 40, x - 40) / 5.0)
    image = image.astype(np.float32)
    geometry = {"centre_px": (40, 40), "diameter_deg": 0.2, "pixel_deg": 0.01}
    first = MODEL.percept(image, **geometry)
    assert MODEL.percept(image.copy(), **geometry) == first
    assert MODEL.percept(image.astype(np.float64), **geometry) == first
    scaled = MODEL.percept(image.astype(np.float64) * scale, **geometry)
    assert_allclose(scaled.brightness_cd_m2, first.brightness_cd_m2 * scale, rtol=1e-9)
    assert_allclose(
        [scaled.glow, scaled.ring, scaled.apparent_diameter_deg],
        [first.glow, first.ring, first.apparent_diameter_deg],
        rtol=1e-9,
        atol=1e-12,
    )


def test_extremes_black_saturated_and_tiny_images():
    """A black image, a uniform (saturated) image and a 3 × 3 image give finite percepts."""
    black = look(np.zeros((161, 161)))
    assert black == Percept(0.0, 0.0, 0.0, black.apparent_diameter_deg, 0.0)
    assert black.boost == 0.0
    uniform = look(np.full((161, 161), 1e9))
    assert uniform.glow == 0.0 and uniform.brightness_cd_m2 >= 1e9
    tiny = MODEL.percept(np.full((3, 3), 5.0), centre_px=(1, 1), diameter_deg=0.03, pixel_deg=0.01)
    assert math.isfinite(tiny.brightness_cd_m2)


# --- input validation -------------------------------------------------------------------------


GOOD = {"centre_px": (5, 5), "diameter_deg": 0.1, "pixel_deg": 0.01}


@pytest.mark.parametrize(
    ("image", "changes", "message"),
    [
        (np.ones(11), {}, r"image_cd_m2 must be a 2-D"),
        (np.full((11, 11), np.nan), {}, r"image_cd_m2 must be finite"),
        (-np.ones((11, 11)), {}, r"image_cd_m2 must be >= 0"),
        (np.full((11, 11), "a"), {}, r"image_cd_m2 must hold real numbers"),
        (np.ones((11, 11)), {"centre_px": (11, 5)}, r"centre_px must lie inside.*rows 0-10"),
        (np.ones((11, 11)), {"centre_px": (5, -0.5)}, r"centre_px must lie inside.*\(5, -0.5\)"),
        (np.ones((11, 11)), {"centre_px": (5, float("nan"))}, r"centre_px must lie inside"),
        (np.ones((11, 11)), {"centre_px": (5,)}, r"centre_px must be two numbers"),
        (np.ones((11, 11)), {"centre_px": "middle"}, r"centre_px must be two numbers"),
        (np.ones((11, 11)), {"diameter_deg": 0.0}, r"diameter_deg must be a finite number > 0"),
        (np.ones((11, 11)), {"diameter_deg": float("inf")}, r"diameter_deg .* got inf"),
        (np.ones((11, 11)), {"pixel_deg": -0.01}, r"pixel_deg must be a finite number > 0"),
    ],
)
def test_bad_input_is_refused_with_its_name_value_and_what_is_allowed(image, changes, message):
    with pytest.raises(ValueError, match=message):
        MODEL.percept(image, **{**GOOD, **changes})


@pytest.mark.parametrize(
    ("cls", "changes", "message"),
    [
        (BrightnessModel, {"glow_half": 0.0}, r"glow_half must be a finite number > 0"),
        (BrightnessModel, {"size_exponent": 2.0}, r"size_exponent must be in \[0, 1\]"),
        (BrightnessModel, {"sectors": 0}, r"sectors must be an integer >= 1"),
        (BrightnessModel, {"plateau_tolerance": 0.0}, r"plateau_tolerance must be in \(0"),
        (BrightnessModel, {"glow_band_deg": -1.0}, r"glow_band_deg must be a finite number"),
        (ObserverNoise, {"gain_sd": -0.1}, r"gain_sd must be in \[0, 5\]"),
        (ObserverNoise, {"margin": 0.5}, r"margin must be in \[0, 0.5\)"),
        (ObserverNoise, {"block_sd": float("nan")}, r"block_sd must be in"),
    ],
)
def test_bad_parameters_are_refused(cls, changes, message):
    with pytest.raises(ValueError, match=message):
        cls(**changes)


def test_randomness_only_through_a_generator():
    with pytest.raises(
        ValueError,
        match=r"rng must be a numpy.random.Generator \(np.random.default_rng\(seed\)\); got 42",
    ):
        ObserverNoise().draw(42)


def test_an_unresolved_disk_warns():
    with pytest.warns(UserWarning, match=r"narrower than 3 pixels"):
        MODEL.percept(np.ones((21, 21)), centre_px=(10, 10), diameter_deg=0.02, pixel_deg=0.01)


# --- observers --------------------------------------------------------------------------------


def test_observer_settings_answers_and_comparisons():
    glow = look(with_glare(glare.GaussianGlare(sigma_deg=0.34), 2000.0))
    plain = look(disk_image(L_DMAX, 150.0)[0])
    quiet = ObserverNoise(
        setting_sd=0.0,
        glow_criterion_sd=0.0,
        ring_criterion_sd=0.0,
        size_tolerance_sd=0.0,
        comparison_sd=0.0,
    )
    rng = np.random.default_rng(0)
    none = Observer(gain=0.0, noise=quiet)
    assert none.brightness(glow) == glow.disk_cd_m2  # no illusion at gain 0
    assert none.settings(plain, rng) == pytest.approx((L_DMAX * 0.92, L_DMAX * 1.08))
    typical = Observer(gain=1.0, noise=quiet)
    assert typical.brightness(glow) == glow.brightness_cd_m2
    assert typical.answers(plain, plain, rng) == (False, False, True)
    assert typical.answers(glow, plain, rng)[0] is True
    assert typical.compare(glow, plain, rng) == "first"
    assert typical.compare(plain, glow, rng) == "second"
    assert typical.compare(plain, plain, rng) == "neither"
    assert typical.compare(plain, plain, rng, shift=0.5) == "first"


def test_identical_methods_give_no_method_effect():
    """Two "methods" whose images are identical: over many simulated 10-observer studies the
    method effect of the 6 × 2 repeated-measures ANOVA has p < .05 at the nominal rate (inside
    the 99.9 % binomial interval around .05)."""
    noise = ObserverNoise()
    images = [
        with_glare(glare.GaussianGlare(sigma_deg=0.34), level)
        for level in (220.0, 600.0, 1100.0, 2000.0, 3000.0, 7000.0)
    ]
    percepts = [look(image) for image in images]
    studies, observers = 600, 10
    rng = np.random.default_rng(14)
    match = np.empty((studies, observers, 6, 2))
    for k in range(studies):
        for s in range(observers):
            observer = noise.draw(rng)
            for level, percept in enumerate(percepts):
                for method in range(2):  # both methods show the very same image
                    match[k, s, level, method] = np.mean(observer.settings(percept, rng))
    # with two methods, the ANOVA's method F is the squared paired t of the observers' means
    difference = match[..., 0].mean(-1) - match[..., 1].mean(-1)
    t = difference.mean(1) / (difference.std(1, ddof=1) / math.sqrt(observers))
    p = 2 * sps.t.sf(np.abs(t), observers - 1)
    for k in range(2):
        rows = [
            {"participant": s, "L_disk": level, "method": m, "match": match[k, s, level, m]}
            for s in range(observers)
            for level in range(6)
            for m in range(2)
        ]
        table = rm_anova(pd.DataFrame(rows), "match", ["L_disk", "method"], "participant")
        assert_allclose(table.set_index("source").loc["method", "p"], p[k], rtol=1e-9)
    low, high = sps.binom.ppf([0.0005, 0.9995], studies, 0.05) / studies
    assert low <= np.mean(p < 0.05) <= high
    # and the levels, which differ in the images, do differ
    assert np.mean(match[:, :, 5].mean((0, 1, 2))) > np.mean(match[:, :, 0].mean((0, 1, 2)))


# --- Luidolt 2020 §7.2.1 ratings -------------------------------------------------------------


def test_the_luidolt_protocols_rating_observers_follow_7_2_1():
    """Expected values against every statement of §7.2.1 (5 participants)."""
    from glarelab.experiments.rating import RatingObserver
    from glarelab.protocols import load_protocol

    protocol = load_protocol("luidolt2020")
    observer = RatingObserver(protocol, "sim01", seed=0)
    categories = protocol["questionnaire"]["categories"]
    p = observer.probabilities
    for category in categories:
        assert p[category].shape == (7,) and (p[category] >= 0).all()
        assert_allclose(p[category].sum(), 1.0, rtol=1e-12)
    # "only the glare appearance voted 3.9 on average"; the five others at 5 or above
    assert_allclose(observer.expected("Glare Appearance"), 3.9, rtol=1e-12)
    assert all(observer.expected(c) >= 5.0 for c in categories[1:])
    # visual acuity: four of five "entirely equal" (7), so its mean is at least 5.8
    assert_allclose(5 * p["Visual Acuity"][6], 4.0)
    assert observer.expected("Visual Acuity") >= 5.8
    # overall: one "neither good nor bad" (4), the others 5 or 6, "no one rated it as perfect"
    assert_allclose(5 * p["Overall"][3], 1.0)
    assert_allclose(p["Overall"][4] + p["Overall"][5], 0.8)
    assert p["Overall"][6] == 0.0 and p["Overall"][:3].sum() == 0.0
    assert 5.0 <= observer.expected("Overall") <= 5.6
    # glare movement: one "just perfect"; scotopic vision: two "completely matched"
    assert_allclose(5 * p["Glare Movement"][6], 1.0)
    assert_allclose(5 * p["Scotopic Vision"][6], 2.0)
    ratings = [
        int(RatingObserver(protocol, f"sim{i}", seed=7).keys(
            {"kind": "rate", "trial": 6, "category": "Overall"}
        )[0][0])
        for i in range(400)
    ]  # fmt: skip
    assert set(ratings) <= {4, 5, 6}
    assert_allclose(np.mean(ratings), observer.expected("Overall"), atol=0.15)
