"""GlareRenderer: one kernel and its spectra for many images, exact paths equal to a plain
convolution, and a model interface that refuses or handles what it does not know."""

from dataclasses import dataclass

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.signal import fftconvolve

from glarelab import glare
from glarelab.glare import GaussianGlare, GlareModel, GlareRenderer, VosGlare
from glarelab.glare.rendering.compose import compose
from glarelab.glare.rendering.renderer import SPECTRA_BYTES


def _night(shape, lamps, seed=0):
    rng = np.random.default_rng(seed)
    image = 10 ** rng.uniform(-2, 0, shape)
    for _ in range(lamps):
        row, col = rng.integers(0, shape[0] - 2), rng.integers(0, shape[1] - 2)
        image[row : row + 3, col : col + 3] = 10 ** rng.uniform(3, 6)
    return image


@pytest.mark.parametrize("path", ["direct", "fft"])
@pytest.mark.parametrize("method", ["Yoshida2008", "Spencer1995"])
def test_the_exact_paths_equal_a_plain_convolution_with_the_full_kernel(path, method):
    image = _night((57, 90), 3)
    model = VosGlare(regime="mesopic")
    kernel = model.kernel(0.05, glare.kernel_shape_for(image.shape))
    result = GlareRenderer(
        model, pixel_deg=0.05, shape=image.shape, composition=method, tolerance_codes=0,
        kernel=kernel, paths=(path,),
    ).render(image)  # fmt: skip
    assert result.plan.path == path and result.plan.exact
    spread = fftconvolve(np.maximum(image - 220.0, 0.0), kernel.values, mode="same")
    assert_allclose(result.spread, spread, rtol=1e-9, atol=1e-9 * spread.max())
    assert_allclose(result.image, compose(image, spread, 220.0, method), rtol=1e-9, atol=1e-9)


def test_a_renderer_digitises_its_kernel_once_and_keeps_its_spectra_bounded():
    lines = []
    renderer = GlareRenderer(
        VosGlare(), pixel_deg=0.05, shape=(96, 128), log=lines.append, cache=False
    )
    for seed in range(4):
        result = renderer.render(_night((96, 128), 40, seed))
        assert result.plan.path == "fft" and result.error_bound_codes <= 0.5
    assert sum("digitising" in line for line in lines) == 1
    assert 1 <= len(renderer._spectra) and all(
        s.dtype == complex for s in renderer._spectra.values()
    )
    assert sum(s.nbytes for s in renderer._spectra.values()) <= SPECTRA_BYTES


def test_a_few_glints_take_the_direct_path_and_many_lamps_the_fft():
    renderer = GlareRenderer(VosGlare(), pixel_deg=0.02, shape=(512, 512))
    glint = np.full((512, 512), 0.3)
    glint[3:5, 500:502] = 1e8  # near a corner: the border case of issue 13
    assert renderer.plan(glint).path == "direct"
    assert renderer.plan(_night((512, 512), 200)).path == "fft"


def test_an_achromatic_rgb_scene_is_convolved_once_and_a_coloured_one_three_times():
    grey = _night((40, 50), 2)
    rgb = np.repeat(grey[..., None], 3, axis=2)
    renderer = GlareRenderer(VosGlare(), pixel_deg=0.05, shape=grey.shape, tolerance_codes=0)
    one = renderer.render(rgb)
    assert one.plan.convolutions == 1 and one.image.shape == rgb.shape
    assert_allclose(one.image[..., 1], renderer.render(grey).image, rtol=1e-12)
    tinted = rgb * np.array([1.0, 0.8, 0.6])
    assert renderer.render(tinted).plan.convolutions == 3


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"shape": (0, 4)}, "shape"),
        ({"paths": ("fast",)}, "paths"),
        ({"paths": ()}, "paths"),
        ({"tolerance_codes": -1}, "tolerance_codes"),
        ({"precision": "float16"}, "precision"),
        ({"composition": "Kakimoto"}, "composition"),
    ],
)
def test_bad_renderer_arguments_are_named(options, match):
    arguments = {"pixel_deg": 0.05, "shape": (8, 8)} | options
    with pytest.raises(ValueError, match=match):
        GlareRenderer(VosGlare(), **arguments)


def test_an_image_of_another_shape_is_refused():
    renderer = GlareRenderer(VosGlare(), pixel_deg=0.05, shape=(8, 8))
    with pytest.raises(ValueError, match=r"luminance_cd_m2 must have the renderer's shape"):
        renderer.render(np.zeros((8, 9)))


@dataclass(frozen=True)
class _PlainBox:
    """A model written to the old protocol: a kernel method and nothing else."""

    def kernel(self, pixel_deg, shape, *, colour=False):
        values = np.ones(shape) / np.prod(shape)
        if colour:
            values = np.repeat(values[..., None], 3, axis=2)
        return glare.Kernel(values=values, pixel_deg=pixel_deg)


def test_a_model_that_declares_nothing_is_rendered_exactly_and_described_truthfully():
    image = np.full((20, 20, 3), 10.0)
    image[10, 10] = 1e4
    result = glare.render_planned(image, _PlainBox(), pixel_deg=0.1, l_dmax_cd_m2=220.0)
    plan = result.plan
    assert plan.exact and plan.colour_kernel and plan.convolutions == 3  # kernel may differ
    assert plan.halo == "not declared by the model (colour kernel)"
    assert "no tail bound" in str(plan)
    with pytest.raises(ValueError, match="model must be a glare model"):
        GlareRenderer(object(), pixel_deg=0.1, shape=(4, 4))


def test_the_models_declare_their_capabilities():
    assert GaussianGlare().achromatic and GaussianGlare().halo() == "none in this model"
    assert VosGlare().achromatic and not VosGlare(regime="scotopic").achromatic
    assert VosGlare(regime="scotopic").halo() == "included"
    assert VosGlare(flare_lines=True).tail_bound(0.1, np.arange(3)) is None
    assert glare.WaveOpticsGlare().tail_bound(0.1, np.arange(3)) is None
    assert all(isinstance(m(), GlareModel) for m in set(glare.GLARE_MODELS.values()))


def test_a_grey_scene_given_a_colour_kernel_reports_the_channel_it_was_rendered_with():
    model = VosGlare(regime="mesopic")
    rgb = model.kernel(0.05, (63, 63), colour=True)
    image = np.full((32, 32), 30.0)
    image[10:12, 20:22] = 1e6
    result = GlareRenderer(model, pixel_deg=0.05, shape=image.shape, kernel=rgb).render(image)
    first = rgb.replace(values=rgb.values[..., 0], energy_outside=float(rgb.energy_outside[0]))
    alone = GlareRenderer(model, pixel_deg=0.05, shape=image.shape, kernel=first).render(image)
    assert result.kernel.shape == (63, 63) and np.ndim(result.kernel.energy_outside) == 0
    # float32 spans from the channel's quadrant and from the full kernel: the same terms,
    # summed in another order (within span_roundoff's 3.9e-6 of each other)
    assert result.plan.direct_precision == alone.plan.direct_precision == "float32"
    assert_allclose(result.image, alone.image, rtol=1e-6, atol=0)
    assert_allclose(result.energy_outside_image, alone.energy_outside_image, rtol=1e-6, atol=0)
    assert_allclose(result.energy_outside_kernel, alone.energy_outside_kernel, rtol=1e-12, atol=0)


@pytest.mark.parametrize("channels", [(), (3,)])
@pytest.mark.parametrize("form", ["quadrant", "values"])
def test_the_kernel_norms_are_the_full_kernels_sums(form, channels):
    """``Σ|K|`` and ``(ΣK²)^½`` (the round-off bound's), and the same of each row and column,
    summed by blocks of rows and, for a quadrant, unfolded for the offsets it stands for: the
    sums over the unfolded kernel, the largest channel's; rows past several blocks."""
    from glarelab.glare.models.digitise import Kernel, mirror_quadrant

    rng = np.random.default_rng(7)
    quadrant = rng.random((301, 283, *channels))
    quadrant /= mirror_quadrant(quadrant).sum(axis=(0, 1)).max()  # a kernel sums to <= 1
    full = mirror_quadrant(quadrant)
    given = (  # made by hand: no model in its description
        Kernel(quadrant=quadrant, pixel_deg=0.05)
        if form == "quadrant"
        else Kernel(full, pixel_deg=0.05)
    )
    renderer = GlareRenderer(VosGlare(), pixel_deg=0.05, shape=(64, 64), kernel=given, cache=False)
    l1 = np.abs(full).sum(axis=(0, 1))
    l2 = np.sqrt((full * full).sum(axis=(0, 1)))
    colour = bool(channels)
    assert_allclose(renderer.kernel_norms(colour), (l1.max(), l2.max()), rtol=1e-13)
    for axis, lines in zip((1, 0), renderer.kernel_lines(colour), strict=True):
        expected = (np.abs(full).sum(axis=axis), (full * full).sum(axis=axis))
        for got, want in zip(lines, expected, strict=True):
            want = want.reshape(want.shape[0], -1).max(axis=1)  # the largest channel's
            assert_allclose(got, want, rtol=1e-12, atol=0)


def test_an_l_dmax_above_the_displays_white_is_refused():
    """Rendered for 500 cd/m² and counted on a display of white 433, the image held
    luminances the display cannot show, without a word."""
    from glarelab.glare import Display

    display = Display.gamma(433.0, black_cd_m2=0.4)
    with pytest.raises(ValueError, match="above the display's white"):
        GlareRenderer(VosGlare(), pixel_deg=0.05, shape=(8, 8), l_dmax_cd_m2=500.0,
                      display=display, cache=False)  # fmt: skip
    kept = GlareRenderer(VosGlare(), pixel_deg=0.05, shape=(8, 8), l_dmax_cd_m2=300.0,
                         display=display, cache=False)  # fmt: skip
    assert kept.l_dmax == 300.0


def test_a_log_that_cannot_be_called_is_refused_when_the_renderer_is_made():
    """log=5 was taken and failed at the first render: 'int' object is not callable."""
    with pytest.raises(ValueError, match="log must be a function"):
        GlareRenderer(VosGlare(), pixel_deg=0.05, shape=(8, 8), log=5, cache=False)


def test_an_image_too_large_for_the_memory_is_refused_before_allocation():
    """A 100000² image was allocated until the system killed the process."""
    import re

    from glarelab.files.memory import available_memory
    from glarelab.glare import GaussianGlare, GlareRenderer, add_glare, render_glare

    if available_memory() is None:
        pytest.skip("the system reports no available memory")
    huge = np.broadcast_to(np.float64(300.0), (100_000, 100_000))  # 8 bytes held, not 80 GB
    refused = re.compile(
        r"shape \(100000, 100000\) needs about [\d.]+ GiB of memory, [\d.]+ GiB are available"
    )
    for render in (render_glare, add_glare):
        with pytest.raises(ValueError, match=refused):
            render(huge, GaussianGlare(0.1), pixel_deg=0.05)
    with pytest.raises(ValueError, match=refused):
        GlareRenderer(GaussianGlare(0.1), pixel_deg=0.05, shape=(100_000, 100_000))
    small = GlareRenderer(GaussianGlare(0.1), pixel_deg=0.05, shape=(31, 31))
    assert small.render(np.full((31, 31), 300.0)).image.shape == (31, 31)


def _point_scene() -> np.ndarray:
    image = np.full((31, 31), 100.0)
    image[15, 15] = 1e4
    return image


@pytest.mark.parametrize(
    ("values", "refused"),
    [
        (np.full((3, 3), np.nan), r"kernel must be finite; got nan at index \(0, 0\)"),
        (np.array([[0, 0, 0], [0, 1.2, 0], [0, -0.2, 0]]), r"kernel must be >= 0"),
        (np.full((3, 3), 5.0), r"kernel sums to 45; a kernel holds at most"),
    ],
)
def test_a_kernel_given_with_nan_negative_values_or_too_much_light_is_refused(values, refused):
    """They rendered without a word: NaN pixels, light taken away, or 45 times the energy."""
    from glarelab.glare import Kernel, render_glare

    given = Kernel(values=values, pixel_deg=0.05, description={"model": "GaussianGlare"})
    with pytest.raises(ValueError, match=refused):
        render_glare(_point_scene(), GaussianGlare(0.1), pixel_deg=0.05, kernel=given)


def test_a_custom_models_bad_kernel_is_refused():
    from glarelab.glare import Kernel, render_glare

    class NaNModel:
        def kernel(self, pixel_deg, shape, *, colour=False):
            return Kernel(values=np.full(shape, np.nan), pixel_deg=pixel_deg)

    with pytest.raises(ValueError, match=r"the kernel of .* must be finite"):
        render_glare(_point_scene(), NaNModel(), pixel_deg=0.05)

    class OneByOne:  # numpy's "non-broadcastable output operand" reached the user
        def kernel(self, pixel_deg, shape, *, colour=False):
            return Kernel(values=np.ones((1, 1)) / 2, pixel_deg=pixel_deg)

    with pytest.raises(ValueError, match=r"the kernel of .* has shape \(1, 1\), not the "):
        render_glare(_point_scene(), OneByOne(), pixel_deg=0.05)


def test_the_models_kernels_sum_to_at_most_one_and_pass_the_check():
    from glarelab.glare.rendering.renderer import KERNEL_SUM_ROUNDING

    for model in (GaussianGlare(0.1), VosGlare(), glare.WaveOpticsGlare(particles=0)):
        for colour in (False, True):
            kernel = model.kernel(0.05, (61, 61), colour=colour)
            assert np.max(kernel.total()) <= 1.0 + KERNEL_SUM_ROUNDING / 1e6
            given = GlareRenderer(model, pixel_deg=0.05, shape=(31, 31), kernel=kernel)
            assert given.kernel(colour) is not None


@pytest.mark.parametrize("method", ["kernel", "kernel_peak", "kernel_norms", "kernel_lines"])
@pytest.mark.parametrize("colour", ["yes", 1, None])
def test_colour_must_be_true_or_false(method, colour):
    """kernel(colour='yes') returned the colour kernel; digitise_kernel refuses the same."""
    renderer = GlareRenderer(VosGlare(regime="mesopic"), pixel_deg=0.05, shape=(31, 31))
    with pytest.raises(ValueError, match=rf"^colour must be True or False, got {colour!r}$"):
        getattr(renderer, method)(colour=colour)
