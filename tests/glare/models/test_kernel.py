"""A kernel held as its quadrant is the same kernel as its unfolded values: the same sums, the
same image on every render path, and no way to change one of the two without the other."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from glarelab import glare
from glarelab.glare.models.digitise import Kernel, mirror_quadrant

# quadrants of 1 × 1 to 40 × 40 (kernels of 1 × 1 to 79 × 79), 1 or 3 channels, values in
# [0, 1] as a digitised kernel's
quadrants = st.tuples(st.integers(1, 40), st.integers(1, 40), st.sampled_from([(), (3,)])).flatmap(
    lambda s: arrays(
        np.float32,
        (s[0], s[1], *s[2]),
        elements=st.floats(0, 1, width=32, allow_subnormal=False),
    )
)


@settings(max_examples=60, deadline=None)
@given(quadrants)
def test_a_quadrants_total_is_its_unfolded_kernels_at_any_precision(quadrant):
    """Both forms sum in float64 (a float32 quadrant's sum in float32 put the energy account
    of a 1e9 cd/m² source off by tens of cd/m²·px against the same kernel unfolded)."""
    half = Kernel(quadrant=quadrant, pixel_deg=0.1)
    whole = Kernel(values=mirror_quadrant(quadrant), pixel_deg=0.1)
    reference = mirror_quadrant(quadrant.astype(np.float64)).sum(axis=(0, 1))
    np.testing.assert_allclose(half.total(), reference, rtol=1e-12, atol=0)
    np.testing.assert_allclose(whole.total(), reference, rtol=1e-12, atol=0)
    assert np.asarray(half.total()).dtype == np.float64


def test_a_quadrant_kernel_cannot_be_changed_behind_the_renderers_back():
    """The direct path spreads from the quadrant, the FFT path from the unfolded values: an
    edit to either would give two images of one kernel, so both refuse it."""
    kernel = glare.VosGlare().kernel(0.05, (41, 41))
    assert kernel.quadrant is not None
    with pytest.raises(ValueError, match="read-only"):
        kernel.values[20, 20] += 0.5
    with pytest.raises(ValueError, match="read-only"):
        kernel.quadrant[0, 0] += 0.5
    image = np.full((21, 21), 10.0)
    image[10, 10] = 1e6
    images = [
        glare.GlareRenderer(
            glare.VosGlare(),
            pixel_deg=0.05,
            shape=image.shape,
            kernel=kernel,
            paths=(path,),
            tolerance_codes=0,
            cache=False,
        ).render(image)
        for path in ("direct", "fft")
    ]
    assert [r.plan.path for r in images] == ["direct", "fft"]
    np.testing.assert_allclose(images[0].image, images[1].image, rtol=1e-12, atol=1e-9)


@pytest.mark.parametrize(
    "send",
    [lambda k: pickle.loads(pickle.dumps(k)), copy.deepcopy, copy.copy],
    ids=["pickle", "deepcopy", "copy"],
)
def test_a_sent_quadrant_kernel_is_the_quadrant_alone_and_stays_read_only(send):
    """Dask pickles kernels (in renderers) to its workers: once the full kernel has been
    unfolded, sending it too would be five times the quadrant's bytes."""
    quadrant = np.random.default_rng(0).random((300, 300))
    kernel = Kernel(quadrant=quadrant, pixel_deg=0.1, description={"model": "test"})
    kernel.values  # noqa: B018 - unfolded, as after an FFT render
    if send is not copy.copy:
        assert len(pickle.dumps(kernel)) < 1.1 * quadrant.nbytes
    sent = send(kernel)
    np.testing.assert_array_equal(sent.values, kernel.values)
    np.testing.assert_array_equal(sent.quadrant, quadrant)
    assert (sent.pixel_deg, sent.description) == (0.1, {"model": "test"})
    for array in (sent.quadrant, sent.values):
        with pytest.raises(ValueError, match="read-only"):
            array[0, 0] = 1.0
    with pytest.raises(AttributeError, match="not changed"):
        sent.pixel_deg = 0.2


def test_the_energy_account_of_a_render_does_not_depend_on_what_was_asked_before():
    """The total is the quadrant's whether or not the full kernel has been unfolded (by an FFT
    render, a plot): the same image rendered twice gives the same account, to the bit."""
    image = np.full((40, 40), 10.0)
    image[3, 5] = 1e9
    image[30:33, 20:23] = 1e6
    renderer = glare.GlareRenderer(
        glare.VosGlare(),
        pixel_deg=0.05,
        shape=image.shape,
        tolerance_codes=0,
        paths=("direct",),
        cache=False,
    )
    before = renderer.render(image).energy_outside_image
    total = renderer.kernel().total()
    renderer.kernel().values  # noqa: B018 - unfolded, as an FFT render does
    assert renderer.kernel().total() == total
    assert renderer.render(image).energy_outside_image == before


@pytest.mark.parametrize(
    ("fields", "refused"),
    [
        ({"values": np.ones((4, 4)), "pixel_deg": 0.1}, r"values must have odd sizes"),
        ({"values": "abc", "pixel_deg": 0.1}, r"values must be a 2-D or 3-D array of numbers"),
        ({"values": np.ones((3, 3)), "pixel_deg": -1}, r"pixel_deg must be a finite number > 0"),
        ({"values": np.ones(3), "pixel_deg": 0.1}, r"values must be a 2-D \(KH, KW\) or 3-D"),
        ({"quadrant": np.ones((2, 2), bool), "pixel_deg": 0.1}, r"quadrant must hold real"),
    ],
)
def test_a_malformed_kernel_is_refused_when_made(fields, refused):
    """An even shape, a string for values and a negative pixel size were all accepted."""
    with pytest.raises(ValueError, match=refused):
        Kernel(**fields)
