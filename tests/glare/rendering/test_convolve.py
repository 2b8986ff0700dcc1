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
    for kernel, symmetric, unfold in (
        (full, False, 0),
        (quadrant, True, 0),  # read through its views
        (quadrant, True, DIRECT_UNFOLD_PIXELS),  # unfolded, as small kernels are
    ):
        with patch.object(_convolve, "DIRECT_UNFOLD_PIXELS", unfold):
            one, got = (
                direct_spread(
                    excess, origin, kernel, out_box, np.zeros(shape), quadrant=symmetric,
                    workers=threads,
                )
                for threads in (1, workers)
            )  # fmt: skip
        # the threads share the rows: the same sums in the same order, equal to the bit
        assert np.array_equal(got, one)
        assert_allclose(got, reference, rtol=1e-12, atol=0)


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


@pytest.mark.parametrize(("half", "side"), [(80, 64), (3, 256)])
def test_each_pixel_of_a_sparse_scene_is_a_span_under_a_wide_kernel(monkeypatch, half, side):
    """A scene of many single bright pixels (stars, glints through leaves) adds a scaled copy
    of the kernel per pixel: under a kernel as wide as the output, all of them in one pass
    of spans over the output's bands; under a narrow one (7 px over 256, where a span's
    stride would run over 73 values per output pixel it reaches) a correlation per pixel
    from the unfolded kernel. The plain sums either way."""
    calls = []
    function = _convolve._span_spread
    monkeypatch.setattr(
        _convolve, "_span_spread", lambda *a, **k: calls.append(a) or function(*a, **k)
    )
    rng = np.random.default_rng(1)
    excess = np.where(rng.random((side, side)) < 0.01, rng.uniform(1, 2, (side, side)), 0.0)
    quadrant = rng.random((half + 1, half + 1))
    box = (0, side, 0, side)
    got = direct_spread(excess, (0, 0), quadrant, box, np.zeros((side, side)), quadrant=True)
    assert len(calls) == (1 if half == 80 else 0)
    reference = plain_spread(excess, (0, 0), mirror_quadrant(quadrant), box, (side, side))
    assert_allclose(got, reference, rtol=1e-12, atol=0)


def test_a_few_glints_across_a_wide_image_are_correlated_not_laid_out_for_spans(monkeypatch):
    """Two glints at the two ends of a 512 × 4096 image under a 1023² kernel: their spans'
    stride would run over 8,191 values a row, and the kernel's layout (512 × 8,191 values)
    cost most of their time; correlated (a scaled view each), they took 0.4-0.8 of it."""
    calls = []
    function = _convolve._span_spread
    monkeypatch.setattr(
        _convolve, "_span_spread", lambda *a, **k: calls.append(a) or function(*a, **k)
    )
    quadrant = np.random.default_rng(2).random((512, 512))
    excess = np.zeros((512, 4096))
    excess[100, 0] = excess[400, 4095] = 1e6
    box = (0, 512, 0, 4096)
    for precision in ("float64", "float32"):
        got = direct_spread(
            excess, (0, 0), quadrant, box, np.zeros((512, 4096)), quadrant=True,
            precision=precision,
        )  # fmt: skip
        assert calls == []
    reference = np.zeros((512, 4096))
    full = mirror_quadrant(quadrant)
    reference[:, :512] += 1e6 * full[511 - 100 : 1023 - 100, 511:]
    reference[:, -512:] += 1e6 * full[511 - 400 : 1023 - 400, :512]
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
    # the kernel slid over the cluster: no correlation with the cluster (a lone pixel's,
    # correlated with its own pixel, may be)
    assert all(args[1].size == 1 for args in calls), [args[1].shape for args in calls]


@settings(max_examples=120, deadline=None)
@given(
    scene=scenes(),
    band_values=st.sampled_from([1, 7, 64, 1000, _convolve.SPAN_BAND_VALUES]),
    flush=st.sampled_from([1, 3, _convolve.SPAN32_FLUSH_TERMS]),
)
def test_spans_are_the_plain_sums_in_float64_and_within_their_bound_in_float32(
    scene, band_values, flush
):
    """Every bright pixel spread as a span, by bands of any height (down to one row) and
    from the full kernel or its quadrant (whose negative rows are read into a band held
    upside down), is the plain sum in float64 (to 1e-12; ``into`` counts only where the
    kernel reaches: a value read past a row's support lands on zeros or on columns past the
    output's) and within :func:`span_roundoff` of it in float32, pixel by pixel."""
    excess, origin, quadrant, out_box, shape = scene
    full = mirror_quadrant(quadrant)
    reference = plain_spread(excess, origin, full, out_box, shape)
    absolute, relative = _convolve.span_roundoff(
        int(np.count_nonzero(excess)), float(excess.sum())
    )
    for kernel, symmetric in ((full, False), (quadrant, True)):
        for precision in ("float64", "float32"):
            with (
                patch.object(_convolve, "SPAN_BAND_VALUES", band_values),
                patch.object(_convolve, "SPAN32_FLUSH_TERMS", flush),
                patch.object(_convolve, "DIRECT_UNFOLD_PIXELS", 0),
            ):
                got = direct_spread(
                    excess, origin, kernel, out_box, np.full(shape, 0.0), quadrant=symmetric,
                    method="spans", precision=precision,
                )  # fmt: skip
            if precision == "float64":
                assert_allclose(got, reference, rtol=1e-12, atol=0)
            else:
                assert np.all(np.abs(got - reference) <= absolute + relative * reference)


def test_float32_spans_are_summed_a_few_at_a_time():
    """4,096 glints of ``1 + 3 · 2^-18`` cd/m² under a flat kernel: added one after another
    in float32, a sum past 256 rounds each new term's ``3 · 2^-18`` away (below half its
    unit in the last place), 2.7 times the bound (:func:`span_roundoff`) by 4,096 terms;
    summed :data:`SPAN32_FLUSH_TERMS` at a time into float64, the spread keeps the bound."""
    weight = 1.0 + 3.0 * 2.0**-18  # a float32 number
    excess = np.full((64, 64), weight)
    kernel = np.ones((129, 129))  # reaches every pixel from every pixel
    exact = 4096 * weight
    absolute, relative = _convolve.span_roundoff(4096, float(excess.sum()))
    bound = absolute + relative * exact
    sequential = np.float32(0.0)
    for _ in range(4096):
        sequential += np.float32(weight)
    assert abs(float(sequential) - exact) > 2.5 * bound
    got = direct_spread(
        excess, (0, 0), kernel, (0, 64, 0, 64), np.zeros((64, 64)), method="spans",
        precision="float32",
    )  # fmt: skip
    assert np.abs(got - exact).max() <= bound


def test_a_given_group_with_nothing_to_spread_adds_nothing_by_every_method():
    """A caller's groups may hold pixels at zero excess (the groups of ``excess >= 0``): a
    group with none above zero adds nothing, by spans, correlation or the cheapest."""
    kernel = np.random.default_rng(5).random((41, 41))
    excess = np.zeros((6, 6))
    excess[4, 4] = 2.0
    groups = [
        ((slice(0, 2), slice(0, 2)), np.ones((2, 2), bool)),  # all at zero excess
        ((slice(4, 5), slice(4, 5)), np.ones((1, 1), bool)),
    ]
    reference = plain_spread(excess, (3, 3), kernel, (0, 20, 0, 20), (20, 20))
    for method in ("cheapest", "correlation", "spans"):
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
    precision=st.sampled_from(["float64", "float32"]),
    costs=st.none() | st.tuples(*[st.floats(1e-10, 1e-8)] * 3),
    seed=st.integers(0, 2**32 - 1),
)
def test_each_cluster_is_spread_as_cluster_ways_says(box, density, half, precision, costs, seed):
    """The plan prices each cluster by :func:`cluster_ways`; the spread takes that way,
    with the same costs: a correlation or a span per pixel (seen through which of
    ``ndimage.correlate`` and ``_span_spread`` it calls)."""
    rng = np.random.default_rng(seed)
    mask = rng.random(box) < density
    mask.flat[rng.integers(mask.size)] = True
    excess = np.where(mask, rng.uniform(1, 10, box), 0.0)
    kernel = np.ones((half[0] + 1, half[1] + 1))  # a quadrant of half-size ``half``
    side = min(2 * max(half) + 8, 1100)
    out_box = (0, side, 0, side)
    groups = [((slice(0, box[0]), slice(0, box[1])), mask)]
    (expected,) = _convolve.cluster_ways(
        [(box, int(mask.sum()))],
        area=min(side * side, (2 * half[0] + 1) * (2 * half[1] + 1)),
        values=_convolve.span_values(side, box[1] - 1, half[1]),
        layout_values=_convolve.span_layout_values(half[0] + 1, side, box[1] - 1),
        precision=precision,
        costs=costs,
    )
    calls = {"correlation": 0, "spans": 0}
    correlate, spans = _convolve.ndimage.correlate, _convolve._span_spread

    def counted(name, function):
        def call(*args, **kwargs):
            calls[name] += 1
            return function(*args, **kwargs)

        return call

    with (
        patch.object(_convolve.ndimage, "correlate", counted("correlation", correlate)),
        patch.object(_convolve, "_span_spread", counted("spans", spans)),
        patch.object(_convolve, "DIRECT_UNFOLD_PIXELS", 0),
    ):
        direct_spread(
            excess, (side // 2, side // 2), kernel, out_box, np.zeros((side, side)),
            quadrant=True, groups=groups, workers=1, precision=precision, costs=costs,
        )  # fmt: skip
    if expected == "correlation" and mask.size > (2 * half[0] + 1) * (2 * half[1] + 1):
        return  # a cluster larger than the kernel: the kernel slides over it (ndimage.convolve)
    # a single pixel correlated is a scaled view of the kernel: no ndimage call
    taken = [name for name, count in calls.items() if count] or ["correlation"]
    assert taken == [expected], (calls, expected)
