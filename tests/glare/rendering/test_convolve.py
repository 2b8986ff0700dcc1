"""The direct spread: every way of reading the kernel (full, quadrant, any number of threads)
gives the same sums as a plain correlation of the kernel with each bright pixel."""

from __future__ import annotations

from unittest.mock import patch

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab.glare.models.digitise import mirror_quadrant
from glarelab.glare.rendering import _convolve
from glarelab.glare.rendering._convolve import DIRECT_UNFOLD_PIXELS, direct_spread


def plain_spread(excess, origin, kernel, out_box, shape):
    """Σ over bright pixels of the pixel's value times the kernel centred on it, written out
    pixel by pixel (independent of the implementation's windows and correlations)."""
    a, b = kernel.shape[0] // 2, kernel.shape[1] // 2
    into = np.zeros(shape)
    rows, cols = np.mgrid[out_box[0] : out_box[1], out_box[2] : out_box[3]]
    for y, x in zip(*np.nonzero(excess), strict=True):
        dy, dx = rows - (origin[0] + y), cols - (origin[1] + x)
        inside = (np.abs(dy) <= a) & (np.abs(dx) <= b)
        part = np.zeros(rows.shape)
        part[inside] = kernel[dy[inside] + a, dx[inside] + b]
        into[out_box[0] : out_box[1], out_box[2] : out_box[3]] += excess[y, x] * part
    return into


@st.composite
def scenes(draw):
    height, width = draw(st.integers(1, 24)), draw(st.integers(1, 24))
    quadrant = draw(st.tuples(st.integers(1, 30), st.integers(1, 30)))  # kernel half + 1
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    excess = np.zeros((height, width))
    for _ in range(draw(st.integers(1, 4))):  # compact clusters (correlations) ...
        y, x = rng.integers(0, height), rng.integers(0, width)
        h, w = rng.integers(1, 6, 2)
        excess[y : y + h, x : x + w] = rng.uniform(0.5, 10, excess[y : y + h, x : x + w].shape)
    if draw(st.booleans()):  # ... and scattered pixels (scaled copies)
        excess[rng.random((height, width)) < 0.2] = 1e9
    origin = (draw(st.integers(0, 6)), draw(st.integers(0, 6)))
    shape = (
        origin[0] + height + draw(st.integers(0, 6)),
        origin[1] + width + draw(st.integers(0, 6)),
    )
    r0 = draw(st.integers(0, shape[0] - 1))
    c0 = draw(st.integers(0, shape[1] - 1))
    out_box = (r0, draw(st.integers(r0 + 1, shape[0])), c0, draw(st.integers(c0 + 1, shape[1])))
    return excess, origin, rng.random(quadrant), out_box, shape


@settings(max_examples=150, deadline=None)
@given(scenes(), st.integers(1, 4))
def test_a_quadrant_spread_equals_the_full_kernels_at_every_thread_count(scene, workers):
    excess, origin, quadrant, out_box, shape = scene
    full = mirror_quadrant(quadrant)
    reference = plain_spread(excess, origin, full, out_box, shape)
    one = direct_spread(excess, origin, full, out_box, np.zeros(shape), workers=1)
    assert_allclose(one, reference, rtol=1e-12, atol=0)
    for kernel, symmetric, unfold in (
        (full, False, 0),
        (quadrant, True, 0),  # read through its views
        (quadrant, True, DIRECT_UNFOLD_PIXELS),  # unfolded, as small kernels are
    ):
        # the same sums in the same order: equal to the bit, not within a tolerance
        with patch.object(_convolve, "DIRECT_UNFOLD_PIXELS", unfold):
            got = direct_spread(
                excess, origin, kernel, out_box, np.zeros(shape), quadrant=symmetric,
                workers=workers,
            )  # fmt: skip
        assert np.array_equal(got, one)


def test_the_spread_from_a_reversed_view_adds_to_what_is_there_and_only_in_the_box():
    quadrant = np.array([[4.0, 2.0, 1.0], [2.0, 1.0, 0.5]])  # offsets 0..1 rows, 0..2 cols
    excess = np.zeros((5, 7))
    excess[2, 3] = 1.0
    into = np.full((5, 7), 10.0)
    with patch.object(_convolve, "DIRECT_UNFOLD_PIXELS", 0):
        direct_spread(excess, (0, 0), quadrant, (1, 4, 0, 7), into, quadrant=True, workers=2)
    expected = np.full((5, 7), 10.0)
    expected[1:4, 1:6] += mirror_quadrant(quadrant)
    assert_allclose(into, expected, rtol=0, atol=0)


def test_each_pixel_of_a_sparse_scene_adds_one_view_of_a_small_kernel(monkeypatch):
    """A scene of many single bright pixels (stars, glints through leaves) adds a scaled copy
    of the kernel per pixel: read from a small quadrant in up to nine pieces (negative, zero
    and positive offsets on each axis), that was 2-3 times the time of one view of the full
    kernel; a small quadrant is unfolded instead, and the sums are the same."""
    pieces = []
    window = _convolve._window
    monkeypatch.setattr(_convolve, "_window", lambda *args: pieces.append(args) or window(*args))
    rng = np.random.default_rng(1)
    excess = np.where(rng.random((64, 64)) < 0.02, rng.uniform(1, 2, (64, 64)), 0.0)
    quadrant = rng.random((11, 11))
    got = direct_spread(
        excess, (0, 0), quadrant, (0, 64, 0, 64), np.zeros((64, 64)), quadrant=True, workers=2
    )
    assert pieces == []
    reference = plain_spread(excess, (0, 0), mirror_quadrant(quadrant), (0, 64, 0, 64), (64, 64))
    assert_allclose(got, reference, rtol=1e-12, atol=0)


@settings(max_examples=60, deadline=None)
@given(
    a_shape=st.tuples(st.integers(1, 40), st.integers(1, 40)),
    b_shape=st.tuples(st.integers(1, 40), st.integers(1, 40)),
    dtypes=st.sampled_from(
        [(np.float64, np.float64), (np.float32, np.float32), (np.float32, np.float64)]
    ),
    seed=st.integers(0, 2**32 - 1),
)
def test_the_full_convolution_is_fftconvolves_to_the_bit(a_shape, b_shape, dtypes, seed):
    """The spread's convolution (without importing scipy.signal) is the same numbers, dtype
    and shape as ``scipy.signal.fftconvolve(mode='full')``, one-pixel axes included."""
    from scipy.signal import fftconvolve

    rng = np.random.default_rng(seed)
    a = (rng.random(a_shape) * 10.0 ** rng.integers(-3, 9)).astype(dtypes[0])
    b = rng.random(b_shape).astype(dtypes[1])
    expected = fftconvolve(a, b, mode="full")
    got = _convolve._full_convolution(a, b)
    assert got.dtype == expected.dtype and got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)


def test_a_cluster_larger_than_the_kernel_slides_the_kernel_over_it(monkeypatch):
    """A bright sky (80 % of the pixels over L_dmax, one cluster) under a kernel smaller than
    it was correlated with the cluster as ndimage's filter, whose table of offsets grows as
    the filter's size squared: a 300 × 256 sky under a 3 × 3 kernel raised MemoryError. The
    kernel is now the filter; the sums are the plain ones, for the full kernel, its quadrant
    and any number of threads."""
    calls = []
    correlate = _convolve.ndimage.correlate
    monkeypatch.setattr(
        _convolve.ndimage, "correlate", lambda *a, **k: calls.append(a) or correlate(*a, **k)
    )
    rng = np.random.default_rng(3)
    excess = np.where(rng.random((40, 36)) < 0.8, rng.uniform(1, 80, (40, 36)), 0.0)
    quadrant = rng.random((2, 3))
    full = mirror_quadrant(quadrant)
    shape, out_box = (46, 40), (0, 46, 3, 40)
    reference = plain_spread(excess, (2, 1), full, out_box, shape)
    for kernel, symmetric in ((full, False), (quadrant, True)):
        for workers in (1, 2):
            with patch.object(_convolve, "DIRECT_UNFOLD_PIXELS", 0):
                got = direct_spread(
                    excess, (2, 1), kernel, out_box, np.zeros(shape), quadrant=symmetric,
                    workers=workers,
                )  # fmt: skip
            assert_allclose(got, reference, rtol=1e-12, atol=0)
    assert calls == []  # the kernel slid over the cluster: no correlation with the cluster


@settings(max_examples=120, deadline=None)
@given(
    scene=scenes(),
    band_bytes=st.sampled_from([8, 64, 200, 4096, _convolve.COPY_BAND_BYTES]),
    workers=st.integers(1, 3),
    dtype=st.sampled_from([np.float64, np.float32]),
)
def test_a_clusters_copies_sum_as_its_correlation_does_to_the_bit(
    scene, band_bytes, workers, dtype
):
    """A compact cluster's scaled kernel copies, summed by bands of rows of any height, are
    the numbers of ``scipy.ndimage.correlate`` of the kernel with the cluster: the same terms
    added in the same order, whichever path the costs choose and however many threads. In
    float32 (an image kept in float32, rendered exactly) too: the correlation multiplies and
    sums in float64 and rounds each cluster's sum once, and so do the copies."""
    excess, origin, quadrant, out_box, shape = scene
    excess, quadrant = excess.astype(dtype), quadrant.astype(dtype)
    full = mirror_quadrant(quadrant)
    got = {}
    for path, pixel_s in (("copies", 0.0), ("correlation", np.inf)):
        for kernel, symmetric in ((full, False), (quadrant, True)):
            with (
                patch.object(_convolve, "COPY_PIXEL_S", pixel_s),
                patch.object(_convolve, "COPY_BAND_BYTES", band_bytes),
                patch.object(_convolve, "COPY_BOX_SPARE", np.inf),  # every box's copies summed
                patch.object(_convolve, "COPY_BOX_PIXELS", 0),
                patch.object(_convolve, "DIRECT_UNFOLD_PIXELS", 0),
            ):
                got[path, symmetric] = direct_spread(
                    excess, origin, kernel, out_box, np.zeros(shape, dtype), quadrant=symmetric,
                    workers=workers,
                )  # fmt: skip
    reference = plain_spread(excess, origin, full, out_box, shape)
    # float32: the kernel, the excess and each sum added to the image rounded (u = 6e-8 each)
    assert_allclose(got["copies", False], reference, rtol=1e-12 if dtype == np.float64 else 1e-6)
    for symmetric in (False, True):
        assert np.array_equal(got["copies", symmetric], got["correlation", symmetric])


def test_a_sparse_cluster_as_wide_as_the_kernel_copies_each_pixel_over_its_own_reach(
    monkeypatch,
):
    """The copies of a thin cluster (a lamp's outline, 4-connected, its box 15 × 15) under a
    61 × 61 kernel are added pixel by pixel, each over the kernel's reach: summed over the
    box's reach they would cost (60 + 15)² / 61² = 1.5 times the work per pixel. A compact
    2 × 2 cluster's copies are summed over its box's reach ((60 + 2)² / 61² = 1.03)."""
    boxes = []
    copies = _convolve._add_copies
    monkeypatch.setattr(
        _convolve, "_add_copies", lambda w, *a: boxes.append(w.shape) or copies(w, *a)
    )
    monkeypatch.setattr(_convolve, "COPY_BOX_PIXELS", 0)  # the box's shape alone decides
    kernel = np.random.default_rng(4).random((61, 61))
    outline = np.zeros((20, 20))
    outline[2, 2:17] = 5.0  # an L of 29 pixels
    outline[2:17, 16] = 7.0
    compact = np.zeros((20, 20))
    compact[5:7, 5:7] = 3.0
    for excess, boxed in ((outline, False), (compact, True)):
        boxes.clear()
        got = direct_spread(excess, (0, 0), kernel, (0, 20, 0, 20), np.zeros((20, 20)))
        reference = plain_spread(excess, (0, 0), kernel, (0, 20, 0, 20), (20, 20))
        assert_allclose(got, reference, rtol=1e-12, atol=0)
        assert bool(boxes) == boxed, boxes


def test_a_given_group_with_nothing_to_spread_adds_nothing_by_every_method():
    """A caller's groups may hold pixels at zero excess (the groups of ``excess >= 0``): a
    group with none above zero adds nothing, by copies (which found no first term to sum
    and raised IndexError), correlation or the cheapest."""
    kernel = np.random.default_rng(5).random((41, 41))
    excess = np.zeros((6, 6))
    excess[4, 4] = 2.0
    groups = [
        ((slice(0, 2), slice(0, 2)), np.ones((2, 2), bool)),  # all at zero excess
        ((slice(4, 5), slice(4, 5)), np.ones((1, 1), bool)),
    ]
    reference = plain_spread(excess, (3, 3), kernel, (0, 20, 0, 20), (20, 20))
    for method in ("cheapest", "correlation", "copies"):
        with patch.object(_convolve, "COPY_BOX_PIXELS", 0):
            got = direct_spread(
                excess, (3, 3), kernel, (0, 20, 0, 20), np.zeros((20, 20)), groups=groups,
                method=method,
            )  # fmt: skip
        assert_allclose(got, reference, rtol=1e-12, atol=0)
    with pytest.raises(ValueError, match="method must be"):
        direct_spread(excess, (3, 3), kernel, (0, 20, 0, 20), np.zeros((20, 20)), method="fft")


@settings(max_examples=80, deadline=None)
@given(
    box=st.tuples(st.integers(1, 6), st.integers(1, 6)),
    density=st.floats(0.05, 1.0),
    half=st.tuples(st.integers(1, 700), st.integers(1, 700)),
    seed=st.integers(0, 2**32 - 1),
)
def test_each_cluster_is_spread_as_cluster_method_says(box, density, half, seed):
    """The plan prices each cluster by :func:`cluster_method`; the spread takes that way:
    a correlation, its copies summed, or one view of the kernel per pixel (seen through
    which of ``ndimage.correlate`` and ``_add_copies`` it calls)."""
    rng = np.random.default_rng(seed)
    mask = rng.random(box) < density
    mask.flat[rng.integers(mask.size)] = True
    excess = np.where(mask, rng.uniform(1, 10, box), 0.0)
    kernel = np.ones((half[0] + 1, half[1] + 1))  # a quadrant of half-size ``half``
    side = min(2 * max(half) + 8, 1100)
    out_box = (0, side, 0, side)
    groups = [((slice(0, box[0]), slice(0, box[1])), mask)]
    spread = min((2 * half[0] + 1) * (2 * half[1] + 1), side * side)
    expected = _convolve.cluster_method(box, int(mask.sum()), half, spread)
    calls = {"correlation": 0, "copies": 0}
    correlate, copies = _convolve.ndimage.correlate, _convolve._add_copies

    def counted(name, function):
        def call(*args, **kwargs):
            calls[name] += 1
            return function(*args, **kwargs)

        return call

    with (
        patch.object(_convolve.ndimage, "correlate", counted("correlation", correlate)),
        patch.object(_convolve, "_add_copies", counted("copies", copies)),
        patch.object(_convolve, "DIRECT_UNFOLD_PIXELS", 0),
    ):
        direct_spread(
            excess, (side // 2, side // 2), kernel, out_box, np.zeros((side, side)),
            quadrant=True, groups=groups, workers=1,
        )  # fmt: skip
    if expected == "correlation" and mask.size > (2 * half[0] + 1) * (2 * half[1] + 1):
        return  # a cluster larger than the kernel: the kernel slides over it (ndimage.convolve)
    taken = [name for name, count in calls.items() if count] or ["views"]
    assert taken == [expected], (calls, expected)
