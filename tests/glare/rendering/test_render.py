import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from numpy.testing import assert_allclose
from scipy.signal import convolve

from glarelab.glare import GaussianGlare, GlareRenderer, VosGlare, add_glare, render_glare

MODELS = [GaussianGlare(sigma_deg=0.2), VosGlare(), VosGlare(regime="mesopic", flare_lines=True)]


def disk(shape=(101, 101), radius_px=4, inside=4000.0, outside=150.0, centre=None):
    cy, cx = centre if centre is not None else (shape[0] // 2, shape[1] // 2)
    y, x = np.indices(shape)
    image = np.full(shape, outside)
    image[np.hypot(y - cy, x - cx) <= radius_px] = inside
    return image


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_image_without_excess_comes_back_bit_identical(model, dtype):
    image = disk(inside=220.0, outside=100.0).astype(dtype)
    out = add_glare(image, model, pixel_deg=0.05, l_dmax_cd_m2=220.0)
    assert out.dtype == dtype and np.array_equal(out, image)


@settings(max_examples=30, deadline=None)
@given(
    hnp.arrays(
        np.float64,
        st.tuples(st.integers(1, 12), st.integers(1, 12)),
        elements=st.floats(0.0, 220.0),
    )
)
def test_any_displayable_image_is_unchanged(image):
    assert np.array_equal(add_glare(image, "gaussian", pixel_deg=0.1), image)


@pytest.mark.parametrize("model", MODELS)
def test_convolution_conserves_the_energy_of_the_excess(model):
    # kernel inside the image: nothing leaves the frame; what is spread equals ΔL's energy
    # less the reported energy outside the kernel's support (issue: 1e-6 relative)
    image = disk(shape=(201, 201), radius_px=5, inside=7000.0)
    result = render_glare(image, model, pixel_deg=0.02, kernel_shape=(101, 101))
    expected = result.excess_energy * (1 - result.kernel.energy_outside)
    assert_allclose(result.energy_outside_image, 0.0, atol=1e-9 * result.excess_energy)
    assert_allclose(result.spread.sum(), expected, rtol=1e-6)
    assert_allclose(
        result.energy_outside_kernel, result.excess_energy * result.kernel.energy_outside
    )


def test_energy_leaving_the_image_is_reported():
    image = disk(shape=(81, 81), radius_px=3, inside=5000.0, centre=(40, 3))
    result = render_glare(image, VosGlare(), pixel_deg=0.02)  # default kernel reaches everywhere
    assert result.energy_outside_image > 0
    total = result.spread.sum() + result.energy_outside_image + result.energy_outside_kernel
    assert_allclose(total, result.excess_energy, rtol=1e-9)


def test_convolution_is_linear_not_circular():
    # a source at the left edge must not wrap round to the right edge
    rng = np.random.default_rng(0)
    image = rng.uniform(0, 200, (40, 50))
    image[20, 0] = 1e5
    image[5:8, 45:48] = 3e4
    kernel_shape = (31, 41)
    result = render_glare(image, VosGlare(), pixel_deg=0.05, kernel_shape=kernel_shape)
    expected_spread = convolve(result.excess, result.kernel.values, mode="same", method="direct")
    assert_allclose(result.spread, expected_spread, rtol=1e-9, atol=1e-9 * expected_spread.max())
    edge_only = np.zeros((40, 50))
    edge_only[20, 0] = 1e5
    edge = render_glare(edge_only, VosGlare(), pixel_deg=0.05, kernel_shape=kernel_shape)
    reach = np.zeros((40, 50), dtype=bool)
    reach[20 - 15 : 20 + 16, :21] = True  # kernel half-sizes: 15 rows, 20 columns
    assert (edge.spread[reach] > 0).all()
    assert_allclose(edge.spread[~reach], 0.0, atol=1e-9)  # beyond: nothing wraps round


def test_yoshida_adds_back_and_clamps_spencer_does_not():
    image = disk(radius_px=3, inside=10_000.0, outside=10.0)
    yoshida = render_glare(image, VosGlare(), pixel_deg=0.02, composition="Yoshida2008")
    spencer = render_glare(image, VosGlare(), pixel_deg=0.02, composition="Spencer1995")
    assert yoshida.image.max() == 220.0
    assert_allclose(yoshida.image, np.minimum(image + yoshida.spread, 220.0), rtol=0)
    assert spencer.image.max() > 220.0  # "burn-out" (Spencer §5)
    assert_allclose(spencer.image, np.minimum(image, 220.0) + spencer.spread, rtol=0)
    # glare only ever adds light
    assert (yoshida.image >= np.minimum(image, 220.0)).all()


def test_gaussian_glare_around_a_point_has_sigma_in_pixels():
    image = np.zeros((161, 161))
    image[80, 80] = 1220.0
    result = render_glare(
        image, GaussianGlare(sigma_deg=0.34), pixel_deg=0.034, l_dmax_cd_m2=220.0
    )
    _y, x = np.indices(image.shape) - 80
    spread = result.spread / result.spread.sum()
    assert_allclose(np.sqrt((spread * x**2).sum()), 10.0, rtol=1e-3)


@pytest.mark.parametrize("model", MODELS)
def test_float32_path_is_close_to_the_float64_reference(model):
    image = disk(shape=(121, 121), radius_px=6, inside=4000.0)
    ref = add_glare(image, model, pixel_deg=0.0119)
    fast = add_glare(image.astype(np.float32), model, pixel_deg=0.0119, precision="float32")
    assert fast.dtype == np.float32
    assert_allclose(fast, ref, rtol=0, atol=1e-4 * 220.0)


@pytest.mark.parametrize("peak", [220.0 + 1e-9, 1e3, 1e6, 1e9])
def test_extreme_luminances_stay_finite(peak):
    image = np.zeros((64, 64))
    image[32, 32] = peak
    for method in ("Yoshida2008", "Spencer1995"):
        result = render_glare(
            image, VosGlare(regime="scotopic"), pixel_deg=0.01, composition=method
        )
        assert np.isfinite(result.image).all() and (result.image >= 0).all()
        assert_allclose(
            result.spread.sum() + result.energy_outside_image + result.energy_outside_kernel,
            result.excess_energy,
            rtol=1e-9,
        )


def test_empty_and_saturated_images():
    empty = np.zeros((17, 23))
    assert np.array_equal(add_glare(empty, VosGlare(), pixel_deg=0.1), empty)
    saturated = np.full((17, 23), 1e6)
    assert np.array_equal(
        add_glare(saturated, VosGlare(), pixel_deg=0.1), np.full((17, 23), 220.0)
    )


@pytest.mark.parametrize("pixel_deg", [1e-5, 3.0])
def test_tiny_and_huge_pixels(pixel_deg):
    image = disk(shape=(31, 31), radius_px=2, inside=1e5, outside=1.0)
    out = add_glare(image, VosGlare(regime="mesopic"), pixel_deg=pixel_deg)
    assert np.isfinite(out).all() and out.max() <= 220.0


def test_colour_images_get_a_coloured_halo_and_keep_each_channels_energy():
    image = np.zeros((301, 301, 3))
    image[150, 150, :] = 1e6  # a white point source
    result = render_glare(
        image,
        VosGlare(regime="mesopic"),
        pixel_deg=0.02,
        composition="Spencer1995",
        kernel_shape=(301, 301),
    )
    assert result.image.shape == (301, 301, 3)
    totals = result.spread.sum(axis=(0, 1)) + result.energy_outside_kernel
    assert_allclose(totals, result.excess_energy, rtol=1e-9)
    ring = result.image[150, 150 + 150 - 25 : 150 + 150 + 25]  # around 3°
    assert not np.allclose(ring[:, 0], ring[:, 2])  # coloured
    grey = render_glare(image, GaussianGlare(), pixel_deg=0.02, kernel_shape=(101, 101))
    assert_allclose(grey.image[..., 0], grey.image[..., 2], rtol=0)


@pytest.mark.parametrize(
    ("image", "kwargs", "match"),
    [
        (
            np.full((4, 4), np.nan),
            {},
            r"luminance_cd_m2 must be finite .* got nan at index \(0, 0\)",
        ),
        (np.full((4, 4), np.inf), {}, "luminance_cd_m2 must be finite"),
        (np.full((4, 4), -1.0), {}, r"luminance_cd_m2 must be >= 0 cd/m²; got -1.0"),
        (np.ones(5), {}, r"luminance_cd_m2 must be a 2-D \(H, W\) array .* got shape \(5,\)"),
        (np.ones((2, 2, 4)), {}, r"C in \[3\]; got shape \(2, 2, 4\)"),
        (np.ones((2, 2, 2, 2)), {}, "got shape"),
        (
            np.ones((4, 4)),
            {"pixel_deg": 0.0},
            r"pixel_deg must be in \[1e-05, 10\] deg, got 0.0",
        ),
        (np.ones((4, 4)), {"pixel_deg": -1.0}, "pixel_deg"),
        (np.ones((4, 4)), {"l_dmax_cd_m2": 0.0}, "l_dmax_cd_m2 must be a finite number > 0"),
        (np.ones((4, 4)), {"composition": "Kakimoto"}, "composition must be one of 'Yoshida2008'"),
        (np.ones((4, 4)), {"precision": "float16"}, "precision must be one of"),
        (np.ones((4, 4)), {"kernel_shape": (4, 5)}, "shape must be two odd positive integers"),
    ],
)
def test_bad_input_raises_a_clear_error(image, kwargs, match):
    arguments = {"pixel_deg": 0.1, **kwargs}
    with pytest.raises(ValueError, match=match):
        add_glare(image, VosGlare(), **arguments)


def test_input_is_never_modified():
    image = disk()
    before = image.copy()
    add_glare(image, VosGlare(), pixel_deg=0.02)
    assert np.array_equal(image, before)


def test_a_digitised_kernel_can_be_reused():
    image = disk(radius_px=3, inside=5000.0)
    model = VosGlare()
    kernel = model.kernel(0.02, (101, 101))
    reused = render_glare(image, model, pixel_deg=0.02, kernel=kernel)
    fresh = render_glare(image, model, pixel_deg=0.02, kernel_shape=(101, 101))
    assert np.array_equal(reused.image, fresh.image)
    with pytest.raises(ValueError, match=r"kernel was digitised for pixel_deg = 0\.02, not 0\.03"):
        render_glare(image, model, pixel_deg=0.03, kernel=kernel)


@pytest.mark.parametrize("model", [GaussianGlare(sigma_deg=0.05), VosGlare()])
def test_float32_next_to_the_sun_adds_no_noise_to_dark_pixels(model):
    # Spencer Fig. 16: a 7.5e8 cd/m² sun. Float32 FFT round-off would add ±2 cd/m² (and
    # negative light) to dark pixels; the float32 path must stay at the float64 result.
    image = np.full((256, 256), 0.5)
    image[60:64, 60:64] = 7.5e8
    reference = add_glare(image, model, pixel_deg=0.02)
    far = (slice(180, None), slice(180, None))
    for paths in (("fft",), ("direct",)):  # FFT round-off, or sums of scaled kernels
        fast = GlareRenderer(
            model, pixel_deg=0.02, shape=image.shape, precision="float32", paths=paths
        ).render(image.astype(np.float32))
        assert fast.plan.path == paths[0]
        assert fast.image.min() >= 0.5 - 1e-6  # nothing darker than the scene itself
        assert_allclose(fast.image[far], reference[far], rtol=1e-6, atol=1e-5)
    # no FFT, and the spread summed in float64 from float32 spans within their bound: a
    # float32 sum of every source's spread would round once per source
    assert fast.plan.direct_precision == "float32"
    assert fast.parameters["convolution_precision"] == ["float32", "float64"]
    fast = GlareRenderer(
        model, pixel_deg=0.02, shape=image.shape, precision="float32", paths=("fft",)
    ).render(image)
    assert fast.parameters["convolution_precision"] == ["float64"]
    ordinary = np.full((64, 64), 0.5)
    ordinary[30, 30] = 4000.0
    assert render_glare(ordinary, model, pixel_deg=0.02, precision="float32").parameters[
        "convolution_precision"
    ] == ["float32"]


def test_spread_is_linear_in_the_excess_and_shift_equivariant():
    model, pixel = VosGlare(regime="mesopic"), 0.03
    base = np.zeros((81, 81))
    base[40, 40] = 1220.0  # excess 1000 over L_dmax = 220
    one = render_glare(base, model, pixel_deg=pixel, kernel_shape=(61, 61)).spread
    brighter = base.copy()
    brighter[40, 40] = 220.0 + 3000.0
    three = render_glare(brighter, model, pixel_deg=pixel, kernel_shape=(61, 61)).spread
    assert_allclose(three, 3 * one, rtol=1e-9, atol=1e-12)  # linear in ΔL
    shifted = np.roll(base, (5, -7), axis=(0, 1))
    moved = render_glare(shifted, model, pixel_deg=pixel, kernel_shape=(61, 61)).spread
    inner = (slice(20, 61), slice(20, 61))
    assert_allclose(moved[inner], np.roll(one, (5, -7), axis=(0, 1))[inner], rtol=1e-9, atol=1e-9)


@settings(max_examples=20, deadline=None)
@given(st.floats(221.0, 1e9), st.floats(1.01, 100.0))
def test_glare_grows_with_source_luminance(luminance, factor):
    image = np.full((41, 41), 1.0)
    image[20, 20] = luminance
    dim = render_glare(image, VosGlare(), pixel_deg=0.05, composition="Spencer1995").image
    image[20, 20] = 220.0 + (luminance - 220.0) * factor
    bright = render_glare(image, VosGlare(), pixel_deg=0.05, composition="Spencer1995").image
    assert (bright >= dim - 1e-9 * dim).all()


def test_method_is_refused_naming_composition():
    # every composition rule is also a model's name: render_glare(image, "Spencer1995",
    # method="Yoshida2008") read as a choice of model and ran with another meaning
    from glarelab.glare import GlareRenderer, add_glare, plan_glare, render_planned

    image = np.full((9, 9), 100.0)
    image[4, 4] = 1e4
    calls = [
        lambda: render_glare(image, "Spencer1995", pixel_deg=0.05, method="Yoshida2008"),
        lambda: add_glare(image, "vos", pixel_deg=0.05, method="Spencer1995"),
        lambda: add_glare(np.ones((9, 9)), "vos", pixel_deg=0.05, method="Spencer1995"),
        lambda: render_planned(image, "vos", pixel_deg=0.05, l_dmax_cd_m2=220.0, method="x"),
        lambda: plan_glare(image, "vos", pixel_deg=0.05, l_dmax_cd_m2=220.0, method="vos"),
        lambda: GlareRenderer("vos", pixel_deg=0.05, shape=(9, 9), method="Spencer1995"),
    ]
    for call in calls:
        with pytest.raises(
            TypeError, match=r"the glare model is the second argument.*composition="
        ):
            call()
    with pytest.raises(
        ValueError, match="composition must be one of 'Yoshida2008', 'Spencer1995'"
    ):
        render_glare(image, "vos", pixel_deg=0.05, composition="vos")
    spencer = render_glare(image, "vos", pixel_deg=0.05, composition="Spencer1995").image
    assert spencer.max() > 220.0  # Spencer's sum has no clamp
