"""CodeTable: the nearest display codes by a table look-up, equal to display_codes rounded;
CodeBound: its bounds before and after the spread is known."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from glarelab.glare.rendering.display import (
    BLOCK_PX,
    CODE_TABLE_SHIFT,
    CodeBound,
    CodeTable,
    Display,
    block_reduce,
    display_codes,
)


def nearest(image, lut):
    return np.rint(display_codes(image, lut))


luts = st.builds(
    lambda white, black_fraction, gamma, bits: (
        Display.gamma(white, black_cd_m2=white * black_fraction, gamma=gamma, bits=bits).lut
    ),
    st.sampled_from([1e-3, 0.5, 100.0, 433.0, 1e4, 1e9]),
    st.sampled_from([0.0, 1e-4, 1e-3, 0.05]),
    st.floats(1.0, 3.0),
    st.sampled_from([8, 10, 12]),
)


@settings(max_examples=15, deadline=None)
@given(lut=luts, data=st.data())
def test_every_float32_near_each_code_boundary_gets_the_interpolated_code(lut, data):
    # the boundaries of rint: halfway between two codes' luminances, and ±64 floats around
    halfway = ((lut[:-1] + lut[1:]) / 2).astype(np.float32)
    steps = np.arange(-64, 65, dtype=np.int32)
    around = (halfway.view(np.int32)[:, None] + steps[None, :]).ravel().view(np.float32)
    around = around[np.isfinite(around) & (around >= 0)]
    extra = data.draw(
        hnp.arrays(np.float32, st.integers(1, 200),
                   elements=st.floats(0.0, float(np.float32(lut[-1] * 4)), width=32)),
    )  # fmt: skip
    for image in (around, extra, lut.astype(np.float32), np.float32([0.0, lut[0], lut[-1]])):
        np.testing.assert_array_equal(CodeTable(lut)(image), nearest(image, lut))


def test_an_image_keeps_its_shape_and_other_dtypes_are_interpolated():
    lut = Display.gamma(200.0, black_cd_m2=0.2).lut
    image = np.random.default_rng(4).uniform(0.0, 250.0, size=(6, 7, 3))
    table = CodeTable(lut)
    assert table(image.astype(np.float32)).shape == (6, 7, 3)
    np.testing.assert_array_equal(table(image), nearest(image, lut))  # float64: not rounded


def test_a_table_below_zero_is_refused():
    with pytest.raises(ValueError, match="lut must begin at >= 0"):
        CodeTable(np.array([-1.0, 0.0, 1.0]))
    with pytest.raises(ValueError, match="increasing"):
        CodeTable(np.array([1.0, 1.0]))


@pytest.mark.parametrize("black", [0.0005, 0.0003])
def test_the_tables_ends_are_held_where_float32_rounds_them_inwards(black):
    # float32(0.0005) > 0.0005: clipped to it, a black pixel took code 1 of a 12-bit table
    # whose first codes lie within one float32 step (found by the property test above)
    lut = Display.gamma(0.5, black_cd_m2=black, gamma=3.0, bits=12).lut
    ends = np.float32([0.0, lut[0], lut[1], lut[-1], 1.0])
    ends = np.concatenate([ends, np.nextafter(ends, np.float32(0)), np.nextafter(ends, 1)])
    np.testing.assert_array_equal(CodeTable(lut)(ends), nearest(ends, lut))


@pytest.mark.parametrize("bits", [8, 10])
def test_every_float32_of_every_bin_of_two_codes_gets_the_interpolated_code(bits):
    # the bins a code boundary crosses are compared with the least float of the greater code
    # (found by bisection when the table is made): every float of each such bin, checked
    lut = Display.gamma(200.0, black_cd_m2=0.05, bits=bits).lut
    table = CodeTable(lut)
    two = np.flatnonzero(np.isfinite(table._switch))
    assert two.size > lut.size / 2  # most of the codes' boundaries
    starts = (two + table._first).astype(np.int64) << CODE_TABLE_SHIFT
    floats = (starts[:, None] + np.arange(2**CODE_TABLE_SHIFT)).ravel().astype(np.int32)
    image = floats.view(np.float32)
    np.testing.assert_array_equal(table(image), nearest(image, lut))


def test_negative_and_out_of_range_floats_take_the_ends_codes():
    lut = Display.gamma(200.0, black_cd_m2=0.05).lut
    image = np.float32([-0.0, -1e-30, -5.0, -np.inf, 0.0, 1e-30, 0.05, 200.0, 1e9, np.inf])
    assert CodeTable(lut)(image).tolist() == [0, 0, 0, 0, 0, 0, 0, 1023, 1023, 1023]


def _night(rng, shape=(96, 112), floor=(-1.0, 1.0)):
    """A dark street (0.01-1 cd/m²) with a few lamps, and a spread that peaks at them and
    lifts the rest: a floor (log10 cd/m² drawn from ``floor``) and 1/r² wings."""
    image = 10 ** rng.uniform(-2, 0, shape)
    rows, cols = rng.integers(0, shape[0], 6), rng.integers(0, shape[1], 6)
    image[rows, cols] = 10 ** rng.uniform(3, 5, 6)
    y, x = np.indices(shape)
    spread = np.full(shape, 10 ** rng.uniform(*floor))
    for row, col in zip(rows, cols, strict=True):
        spread += 10 ** rng.uniform(2, 4) / (1.0 + (y - row) ** 2 + (x - col) ** 2)
    return image[..., None], spread[..., None]


@pytest.mark.parametrize("method", ["Yoshida2008", "Spencer1995"])
def test_a_blocks_bound_holds_for_each_of_its_pixels(method):
    # the check bounds blocks of 16 × 16 pixels first and looks at the pixels only of blocks
    # over the tolerance: a block's bound (the smaller of two) must be at least each of its
    # pixels' (the bench's display, black 0.5 cd/m², and the reference display)
    rng = np.random.default_rng(35)
    for lut in (
        Display.gamma(433.0, black_cd_m2=0.5).lut,
        Display.gamma(220.0, black_cd_m2=0.22).lut,
    ):
        bound = CodeBound(lut, 220.0, method)
        for absolute, relative in ((0.035, 1.3e-5), (1e-3, 1e-4), (0.3, 0.0), (0.0, 2e-3)):
            planes, spread = _night(rng)
            blocks = bound.codes(planes, spread, absolute=absolute, relative=relative,
                                 tolerance_codes=np.inf)  # fmt: skip
            pixels = bound.codes(planes, spread, absolute=absolute, relative=relative)
            assert pixels > 0 and blocks >= pixels, (absolute, relative, blocks, pixels)


def test_the_bound_before_the_spread_is_known_holds_for_each_pixel():
    # CodeBound.roundoff_codes: from each block's darkest pixel and a lower bound on its
    # spread, at least what codes finds pixel by pixel once the spread is computed (a spread
    # off by at most a + r S of the exact one, S the exact spread, r as float32 FFTs have
    # it). Where the glare lifts the dark pixels well above the display's black (the city at
    # night: to 7.4 cd/m² or more) and the absolute part dominates (the city's a), within
    # 1.5× of it (the relative part is bounded over the whole display)
    rng = np.random.default_rng(36)
    lut = Display.gamma(433.0, black_cd_m2=0.5).lut
    bound = CodeBound(lut, 220.0, "Yoshida2008")
    for (absolute, relative), floor in itertools.product(
        ((0.035, 1.3e-5), (0.005, 2e-5)), ((-1.0, 0.0), (0.5, 1.0))
    ):
        planes, exact = _night(rng, floor=floor)
        computed = np.maximum(exact - (absolute + relative * exact), 0.0)  # the lowest
        darkest = block_reduce(planes[..., 0], np.minimum, BLOCK_PX)
        least = block_reduce(exact[..., 0], np.minimum, BLOCK_PX)
        before = bound.roundoff_codes(darkest, least, absolute=absolute, relative=relative)
        after = bound.codes(planes, computed, absolute=absolute, relative=relative)
        assert after <= before, (after, before)
        if floor[0] > 0 and absolute > 0.01:
            assert before < 1.5 * after, (after, before)


@pytest.mark.parametrize(
    ("options", "pattern"),
    [
        ({"black_cd_m2": True}, "black_cd_m2"),
        ({"black_cd_m2": "0.1"}, "black_cd_m2"),
        ({"black_cd_m2": float("nan")}, "black_cd_m2"),
        ({"black_cd_m2": 100.0}, "black_cd_m2"),
        ({"black_cd_m2": 0.1, "bits": True}, "bits"),
        ({"black_cd_m2": 0.1, "bits": 0}, "bits"),
        ({"black_cd_m2": 0.1, "bits": 10.0}, "bits"),
        ({"black_cd_m2": 0.1, "bits": 40}, "bits"),
        ({"black_cd_m2": 0.1, "gamma": True}, "gamma"),
        ({"black_cd_m2": 0.1, "gamma": [2.2]}, "gamma"),
        ({"black_cd_m2": 0.1, "gamma": float("nan")}, "gamma"),
        ({"black_cd_m2": 0.1, "gamma": float("inf")}, "gamma"),
        ({"black_cd_m2": 0.1, "gamma": -2.2}, "gamma"),
        ({"black_cd_m2": 0.1, "gamma": 0.0}, "gamma"),
        ({"black_cd_m2": 0.1, "gamma": 2.2 + 0j}, "gamma"),
    ],
)
def test_a_gamma_display_refuses_what_cannot_be_a_display(options, pattern):
    """Each of these made a table: a bool as 1 or 0, a string read as its number, NaN and
    negative gammas tables of NaN and inf, 0 bits one code, 40 bits an 8 TiB allocation."""
    with pytest.raises(ValueError, match=pattern):
        Display.gamma(100.0, **options)


def test_a_masked_table_is_refused_not_used_without_its_mask():
    """Display(masked) kept the masked codes as luminances (its white the masked 200 cd/m²)."""
    lut = np.linspace(0.1, 200.0, 256)
    masked = np.ma.array(lut, mask=np.r_[np.zeros(200, bool), np.ones(56, bool)])
    with pytest.raises(ValueError, match="lut must be a plain array, not a masked array"):
        Display(masked)
    with pytest.raises(ValueError, match="display must be a plain array, not a masked array"):
        CodeTable(masked)
