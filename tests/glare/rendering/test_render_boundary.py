"""render_glare and add_glare at their boundary: every bad argument is refused with a
ValueError or TypeError naming it (never another exception, never a NaN image), and the valid
extremes (0 and 1e9 cd/m², pixels from 1e-5° to 10°) give finite images."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from glarelab.glare import (
    GaussianGlare,
    GlareRenderer,
    VosGlare,
    add_glare,
    digitise_kernel,
    kernel_shape_for,
    render_glare,
)

from ..strategies import NOT_A_NUMBER, NOT_FINITE_POSITIVE, SETTINGS

IMAGE = np.full((16, 16), 50.0)
IMAGE[8, 8] = 1e6
MODEL = GaussianGlare(sigma_deg=0.1)

BAD_PIXEL_DEG = st.one_of(
    NOT_A_NUMBER,
    NOT_FINITE_POSITIVE,
    st.floats(10.0, 1e300, exclude_min=True),
    st.floats(0, 9.9e-6),
)
BAD_KERNEL_SHAPE = st.one_of(
    st.tuples(st.integers(-5, 41), st.integers(-5, 41)).filter(
        lambda s: min(s) < 1 or s[0] % 2 == 0 or s[1] % 2 == 0
    ),
    st.tuples(st.floats(1.5, 30.5).filter(lambda x: x != int(x)), st.just(5)),
    st.tuples(st.booleans(), st.booleans()),
    st.tuples(st.integers(1, 5)),
    st.tuples(st.just(5), st.just(5), st.just(5)),
    st.text(max_size=3),
    st.integers(1, 9),
)
BAD_DISPLAY = st.one_of(
    st.text(min_size=1, max_size=8),  # a display's name is no table
    st.just([1.0, 2.0, math.nan]),
    st.just([2.0, 1.0]),
    st.just([[1.0], [2.0, 3.0]]),
    st.just([True, False]),
)
BAD = {
    "display": BAD_DISPLAY,
    "pixel_deg": BAD_PIXEL_DEG,
    "l_dmax_cd_m2": st.one_of(NOT_A_NUMBER, NOT_FINITE_POSITIVE),
    "composition": st.one_of(st.text(max_size=12), st.none(), st.integers()),
    "precision": st.one_of(st.sampled_from(["float16", "int", "Float64"]), st.none()),
    "kernel_shape": BAD_KERNEL_SHAPE,
}


def bad_images():
    """Images that are no luminance image: masked, bool, complex, strings, NaN/Inf, negative,
    of another shape."""
    masked = np.ma.masked_array(IMAGE.copy(), mask=IMAGE > 100)
    return st.one_of(
        st.just("a string"),
        st.just(None),
        st.just([[1.0, 2.0], [3.0]]),  # rows of different lengths
        st.just(masked),
        st.just(IMAGE > 100),
        st.just(IMAGE.astype(complex)),
        st.just(np.full((4, 4), "1")),
        st.just(np.ones(5)),
        st.just(np.ones((4, 4, 2))),
        st.just(np.ones((0, 4))),
        st.tuples(
            st.sampled_from([math.nan, math.inf, -math.inf, -1.0, -1e-300]),
            st.integers(0, 15),
            st.integers(0, 15),
        ).map(_with_pixel),
    )


def _with_pixel(spec) -> np.ndarray:
    value, row, col = spec
    image = IMAGE.copy()
    image[row, col] = value
    return image


@pytest.mark.parametrize("function", [render_glare, add_glare])
@SETTINGS
@given(data=st.data())
def test_a_bad_argument_is_refused_naming_it(function, data):
    name = data.draw(st.sampled_from(sorted(BAD)), label="argument")
    value = data.draw(BAD[name], label=name)
    arguments = {"pixel_deg": 0.05, "cache": False, name: value}
    with pytest.raises((ValueError, TypeError)) as raised:
        function(IMAGE, MODEL, **arguments)
    assert name in str(raised.value)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("function", [render_glare, add_glare])
@SETTINGS
@given(image=bad_images())
def test_a_bad_image_is_refused_naming_it(function, image):
    with pytest.raises((ValueError, TypeError), match="luminance_cd_m2"):
        function(image, MODEL, pixel_deg=0.05, cache=False)


@pytest.mark.parametrize(
    ("value", "match"),
    [
        (True, r"pixel_deg must be a number in \[1e-05, 10\] deg, got True"),
        (1e-300, r"pixel_deg must be in \[1e-05, 10\] deg, got 1e-300"),
        (11.0, r"pixel_deg must be in \[1e-05, 10\] deg, got 11.0"),
    ],
)
def test_the_issue_cases_of_the_pixel_size(value, match):
    with pytest.raises(ValueError, match=match):
        render_glare(IMAGE, MODEL, pixel_deg=value, cache=False)


@SETTINGS
@given(
    tolerance=st.one_of(
        st.booleans(),
        st.text(max_size=4),
        st.floats(max_value=-1e-300),
        st.sampled_from([math.nan, math.inf, -math.inf]),
    ),
    kernel_shape=st.sampled_from([None, (31, 31)]),
    dim=st.booleans(),
)
def test_add_glare_refuses_a_bad_tolerance_whatever_path_it_takes(tolerance, kernel_shape, dim):
    image = np.full((16, 16), 50.0) if dim else IMAGE  # dim: nothing to spread
    with pytest.raises(ValueError, match=r"^tolerance_codes must be a finite number >= 0"):
        add_glare(
            image, MODEL, pixel_deg=0.05, tolerance_codes=tolerance, kernel_shape=kernel_shape,
            cache=False,
        )  # fmt: skip


def test_a_masked_image_is_refused_not_read_without_its_mask():
    image = np.ma.masked_array(IMAGE.copy(), mask=np.zeros(IMAGE.shape, bool))
    image.mask[8, 8] = True  # the sun is masked out: reading .data would spread it
    with pytest.raises(ValueError, match=r"luminance_cd_m2 must be a plain array, not a masked"):
        add_glare(image, MODEL, pixel_deg=0.05, cache=False)


@pytest.mark.parametrize("shape", [(5.5, 5.5), (True, True), (15.0, 15)])
def test_a_kernel_shape_that_is_not_integers_is_refused(shape):
    with pytest.raises(ValueError, match=r"shape must be two odd positive integers"):
        render_glare(IMAGE, MODEL, pixel_deg=0.05, kernel_shape=shape, cache=False)


@SETTINGS
@given(
    pixels=st.lists(st.sampled_from([0.0, 1e9]), min_size=256, max_size=256),
    log_pixel_deg=st.floats(math.log10(1e-5), 1.0),
    model=st.sampled_from([GaussianGlare(sigma_deg=0.1, sampling="pixel"), VosGlare()]),
    composition=st.sampled_from(["Yoshida2008", "Spencer1995"]),
)
def test_valid_extremes_give_finite_images(pixels, log_pixel_deg, model, composition):
    image = np.array(pixels).reshape(16, 16)
    pixel_deg = min(10.0**log_pixel_deg, 10.0)
    result = render_glare(image, model, pixel_deg=pixel_deg, composition=composition, cache=False)
    assert np.isfinite(result.image).all()
    assert np.isfinite(result.excess_energy)
    quick = add_glare(image, model, pixel_deg=pixel_deg, composition=composition, cache=False)
    assert np.isfinite(quick).all()


@pytest.mark.parametrize(
    ("kernel", "match"),
    [
        (np.ones((3, 3)) / 9, r"^kernel must be a Kernel .*got ndarray$"),
        (
            digitise_kernel(VosGlare(), 0.05, (31, 31), cache=False),
            r"^kernel was digitised by VosGlare, not by the model given \(GaussianGlare\)$",
        ),
        (
            digitise_kernel(GaussianGlare(sigma_deg=0.2), 0.05, (31, 31), cache=False),
            r"^kernel was digitised by GaussianGlare with sigma_deg = 0.2, not the model's "
            r"sigma_deg = 0.1$",
        ),
    ],
)
def test_a_kernel_of_another_model_is_refused_not_rendered_under_this_ones_name(kernel, match):
    with pytest.raises((ValueError, TypeError), match=match):
        render_glare(IMAGE, MODEL, pixel_deg=0.05, kernel=kernel, cache=False)


def test_the_models_own_kernel_renders_as_without_it():
    kernel = digitise_kernel(MODEL, 0.05, (31, 31), cache=False)
    given = render_glare(IMAGE, MODEL, pixel_deg=0.05, kernel=kernel, cache=False).image
    made = render_glare(IMAGE, MODEL, pixel_deg=0.05, kernel_shape=(31, 31), cache=False).image
    np.testing.assert_allclose(given, made, rtol=1e-12, atol=0)


def test_a_kernel_shape_beside_a_kernel_of_another_is_refused():
    """The kernel given was used and the shape asked for ignored, without a word."""
    kernel = digitise_kernel(MODEL, 0.05, (9, 9), cache=False)
    with pytest.raises(ValueError, match=r"kernel_shape=\(7, 7\) with a kernel of shape \(9, 9\)"):
        render_glare(IMAGE, MODEL, pixel_deg=0.05, kernel=kernel, kernel_shape=(7, 7))
    render_glare(IMAGE, MODEL, pixel_deg=0.05, kernel=kernel, kernel_shape=(9, 9))


@pytest.mark.parametrize("shape", [(10, 10, 4), (10, 10, 2), (10, 10, 3, 1)])
def test_an_image_shape_of_no_luminance_or_rgb_image_is_refused(shape):
    with pytest.raises(ValueError, match=r"shape must be \(H, W\) or \(H, W, C\) of a luminance"):
        GlareRenderer(MODEL, pixel_deg=0.05, shape=shape)


@pytest.mark.parametrize("shape", ["21x21", (21.5, 21), (True, 21), (0, 5), (5,), None, 7])
def test_an_image_shape_that_is_not_pixel_counts_is_refused(shape):
    with pytest.raises(ValueError, match=r"shape must be \(H, W\) of whole pixel counts >= 1"):
        GlareRenderer(MODEL, pixel_deg=0.05, shape=shape)
    with pytest.raises(ValueError, match=r"image_shape must be \(H, W\) of whole pixel counts"):
        kernel_shape_for(shape)


def test_a_model_class_is_refused_naming_the_object_to_give():
    with pytest.raises(ValueError, match=r"e\.g\. VosGlare\(\), not the class VosGlare itself"):
        add_glare(IMAGE, VosGlare, pixel_deg=0.05, cache=False)


@pytest.mark.parametrize(
    "lut",
    [np.array([0.0, 1.0, 0.5]), np.array([1.0]), np.array([0.0, np.nan, 2.0]),
     np.array([-1.0, 2.0]), "sRGB", None],
    ids=["not increasing", "one code", "NaN", "negative", "a name", "None"],
)  # fmt: skip
def test_a_display_table_no_display_has_is_refused_when_made(lut):
    """``Display(np.array([0, 1, 0.5]))`` was made, and failed only where it was used."""
    from glarelab.glare import Display

    with pytest.raises(ValueError, match=r"^lut must be"):
        Display(lut)


@pytest.mark.parametrize("tolerance", [0, None])
def test_the_far_tail_alone_for_an_exact_render_is_refused(tolerance):
    """It was taken, and an exact path rendered instead without a word."""
    with pytest.raises(ValueError, match=r"paths=\('multires',\) with tolerance_codes="):
        GlareRenderer(MODEL, pixel_deg=0.05, shape=(10, 10), paths=("multires",),
                      tolerance_codes=tolerance)  # fmt: skip


@pytest.mark.parametrize(
    ("options", "named"),
    [({"tolerance_codes": 2.0}, "tolerance_codes"), ({"display": None, "tolerance_codes": 5.0},
     "tolerance_codes")],
)  # fmt: skip
def test_a_plans_options_beside_a_kernel_shape_are_refused(options, named):
    """``add_glare(kernel_shape=..., tolerance_codes=2)`` rendered exactly and ignored the
    tolerance (and the display it is counted on), without a word."""
    from glarelab.glare import Display

    with pytest.raises(ValueError, match=rf"^{named} beside kernel_shape=\(31, 31\)"):
        add_glare(IMAGE, MODEL, pixel_deg=0.05, kernel_shape=(31, 31), **options)
    with pytest.raises(ValueError, match=r"^display beside kernel_shape=\(31, 31\)"):
        add_glare(IMAGE, MODEL, pixel_deg=0.05, kernel_shape=(31, 31),
                  display=Display(np.linspace(0.1, 100.0, 1024)))  # fmt: skip
    exact = render_glare(IMAGE, MODEL, pixel_deg=0.05, kernel_shape=(31, 31), cache=False).image
    for tolerance in (None, 0, 0.5):  # the exact render, and the default left as it is
        shaped = add_glare(IMAGE, MODEL, pixel_deg=0.05, kernel_shape=(31, 31),
                           tolerance_codes=tolerance, cache=False)  # fmt: skip
        np.testing.assert_allclose(shaped, exact, rtol=1e-12, atol=0)


@pytest.mark.parametrize(
    ("value", "options"),
    [(3.5e38, {"precision": "float32"}), (1e306, {}), (1e31, {})],
)
def test_a_luminance_beyond_what_the_arithmetic_holds_is_refused(value, options):
    """A pixel of 3.5e38 cd/m² under float32 became inf in Spencer's sum; an image of 1e306
    cd/m² ended in an IndexError of the code tables."""
    image = np.full((21, 21), 1.0)
    image[10, 10] = value
    for composition in ("Yoshida2008", "Spencer1995"):
        with pytest.raises(ValueError, match=r"^luminance_cd_m2 reaches .* beyond the 1e\+30 "):
            add_glare(image, MODEL, pixel_deg=0.05, composition=composition, **options)
    with pytest.raises(ValueError, match=r"^l_dmax_cd_m2 must be at most 1e\+30 cd/m²"):
        add_glare(image, MODEL, pixel_deg=0.05, l_dmax_cd_m2=1e300)
    image[10, 10] = 1e30  # the largest rendered, finite in both precisions
    for precision in ("float64", "float32"):
        for composition in ("Yoshida2008", "Spencer1995"):
            done = add_glare(image, MODEL, pixel_deg=0.05, composition=composition,
                             precision=precision)  # fmt: skip
            assert np.isfinite(done).all()


@pytest.mark.parametrize("cache", [3, {}, "", 1.5])
def test_a_cache_argument_is_checked_when_nothing_is_spread_too(cache, tmp_path, monkeypatch):
    # an image below l_dmax returned a copy, cache=3 or {} never looked at
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match=r"^cache must"):
        add_glare(np.ones((4, 4)), "gaussian", pixel_deg=0.05, cache=cache)
    assert list(tmp_path.iterdir()) == []


def test_a_float32_luminance_just_beyond_the_limit_is_shown_beyond_it():
    # float32's 1e30 is 1.00000002e+30: shown as 1e+30, "beyond the 1e+30" read as a contradiction
    with pytest.raises(ValueError, match=r"reaches 1\.00000002e\+30 cd/m², beyond the 1e\+30"):
        add_glare(np.full((4, 4), 1e30, np.float32), "gaussian", pixel_deg=0.05, cache=False)
