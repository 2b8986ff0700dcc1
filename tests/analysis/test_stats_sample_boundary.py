"""The tests of glarelab.analysis.stats that take samples, at their boundary: a masked array, a
string, a bool, None or a NaN among the values is refused naming the function, the argument and
the position, never read as a number; so are an ``n`` or a ``count`` that is not a whole number
in range."""

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.analysis.stats import (
    anova_residuals,
    group_letters,
    normality,
    pairwise_tests,
    signed_rank_counts,
    ttest_one_sample,
    ttest_paired,
    ttest_welch,
    wilcoxon_signed_rank,
)

SETTINGS = settings(max_examples=20, deadline=None)
VALUE = st.floats(-1e6, 1e6)
NOT_A_NUMBER = st.one_of(
    st.text(min_size=1, max_size=3),
    st.booleans(),
    st.none(),
    st.complex_numbers(allow_nan=False, allow_infinity=False, min_magnitude=1e-3),
)
PARTNER = [1.0, 2.0, 4.0, 3.5, 7.0, 8.0, 9.0, 1.0]
# each function with one sample, called on it; the name its message gives the sample
SAMPLES = {
    "ttest_one_sample: x": lambda x: ttest_one_sample(x),
    "ttest_paired: a": lambda x: ttest_paired(x, PARTNER[: len(x)]),
    "ttest_paired: b": lambda x: ttest_paired(PARTNER[: len(x)], x),
    "ttest_welch: a": lambda x: ttest_welch(x, [1.0, 2.0, 4.0]),
    "ttest_welch: b": lambda x: ttest_welch([1.0, 2.0, 4.0], x),
    "wilcoxon_signed_rank: x": lambda x: wilcoxon_signed_rank(x, mu=0.5),
    "normality: values": normality,
}


@SETTINGS
@given(
    where=st.sampled_from(sorted(SAMPLES)),
    values=st.lists(VALUE, min_size=8, max_size=8),
    bad=st.one_of(NOT_A_NUMBER, st.sampled_from([math.nan, math.inf, -math.inf])),
    at=st.integers(0, 7),
)
def test_a_value_that_is_not_a_finite_number_is_refused_naming_its_place(where, values, bad, at):
    values[at] = bad
    with pytest.raises((TypeError, ValueError), match=rf"^{where} .* at position {at}") as raised:
        SAMPLES[where](values)
    assert "\n" not in str(raised.value)


@pytest.mark.parametrize("where", sorted(SAMPLES))
def test_a_masked_array_is_refused_not_read_with_its_masked_values(where):
    # ttest_one_sample took the masked 100 in: mean 26.5 and df 3 where mean 2, df 2 was meant
    values = np.ma.masked_array(
        [1.0, 2.0, 100.0, 3.0, 2.5, 4.0, 5.0, 1.5], mask=[0, 0, 1] + [0] * 5
    )
    with pytest.raises(TypeError, match=rf"^{where} must be a plain array, not a masked array"):
        SAMPLES[where](values)
    SAMPLES[where](values.compressed())  # what the message asks for is accepted


def test_strings_are_refused_not_read_as_numbers():
    # ttest_welch(['1', '2', '3'], [1, 2, 3]) gave t = 0, p = 1
    with pytest.raises(TypeError, match=r"^ttest_welch: a must hold real numbers .* '1' at"):
        ttest_welch(["1", "2", "3"], [1, 2, 3])
    with pytest.raises(TypeError, match=r"^ttest_welch: b must be a sequence of numbers"):
        ttest_welch([1, 2, 3], "123")


def test_normality_refuses_a_nan_instead_of_returning_nan():
    # normality([1, 2, nan, 4]) gave W = p = NaN and counted the NaN in n
    with pytest.raises(ValueError, match=r"^normality: values is nan at position 2; every"):
        normality([1.0, 2.0, math.nan, 4.0])


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda v: ttest_one_sample([1.0, 2.0, 4.0], mu=v), "mu"),
        (lambda v: wilcoxon_signed_rank([1.0, 2.0, 4.0], mu=v), "mu"),
        (lambda v: ttest_one_sample([1.0, 2.0, 4.0], confidence=v), "confidence"),
        (lambda v: ttest_welch([1.0, 2.0, 4.0], [2.0, 3.0], confidence=v), "confidence"),
    ],
)
@pytest.mark.parametrize("value", [True, "0.5", None, math.nan])
def test_options_that_are_not_finite_numbers_are_refused_naming_them(call, name, value):
    with pytest.raises((TypeError, ValueError), match=rf"^\w+: {name} must (be|lie)"):
        call(value)


@SETTINGS
@given(
    n=st.one_of(
        st.integers(max_value=-1),
        st.integers(min_value=63),
        st.booleans(),
        st.floats(allow_nan=True),
        st.text(max_size=2),
        st.none(),
    )
)
def test_signed_rank_counts_refuses_an_n_that_is_not_a_count(n):
    # signed_rank_counts(-1) gave [1] and signed_rank_counts(True) gave [1, 1]
    with pytest.raises(ValueError, match=r"^signed_rank_counts: n must be a whole number in"):
        signed_rank_counts(n)


@SETTINGS
@given(n=st.integers(0, 62))
def test_signed_rank_counts_sum_to_two_to_the_n(n):
    counts = signed_rank_counts(n)
    assert counts.size == n * (n + 1) // 2 + 1 and int(counts.sum(dtype=object)) == 2**n


@pytest.mark.parametrize("count", [-1, True, 2.0, "3", None])
def test_group_letters_refuses_a_count_that_is_not_one(count):
    with pytest.raises(ValueError, match=r"^group_letters: count must be a whole number >= 0"):
        group_letters(count)


def _long(values):
    subjects, cells = np.meshgrid(range(3), range(2), indexing="ij")
    return pd.DataFrame({"s": subjects.ravel(), "c": cells.ravel(), "y": values})


@pytest.mark.parametrize(
    ("values", "match"),
    [
        ([1.0, 2.0, math.nan, 4.0, 5.0, 7.0], r"^anova_residuals: dv 'y' is nan in row 2; every"),
        ([1.0, 2.0, math.inf, 4.0, 5.0, 7.0], r"^anova_residuals: dv 'y' is inf in row 2"),
        (["1", "2", "3", "4", "5", "7"], r"^anova_residuals: column dv='y' must be real numbers"),
        ([True, False] * 3, r"^anova_residuals: column dv='y' must be real numbers"),
        ([1, 2, 3, 4, 5, 7 + 1j], r"^anova_residuals: column dv='y' must be real numbers"),
    ],
)
def test_anova_residuals_refuses_what_is_not_a_finite_number(values, match):
    # a NaN dropped out of the pivot and gave NaN residuals for its subject and cell
    with pytest.raises(ValueError, match=match):
        anova_residuals(_long(values), "y", ["c"], "s")


def test_anova_residuals_refuses_a_missing_cell():
    with pytest.raises(
        ValueError,
        match=r"^anova_residuals needs a balanced design: subject 2 has no 'y' at \{'c': 1\}$",
    ):
        anova_residuals(_long(np.arange(6.0)).iloc[:-1], "y", ["c"], "s")


@pytest.mark.parametrize("alpha", [True, "0.05", None, math.nan, 0.0, 1.5])
def test_pairwise_tests_refuses_a_bad_alpha_in_its_own_name(alpha):
    # the alpha was judged by holm_confidence after every test had run, in that function's name
    data = _long([1.0, 2.5, 3.0, 4.5, 5.0, 7.5])
    with pytest.raises((TypeError, ValueError), match=r"^pairwise_tests: alpha must"):
        pairwise_tests(data, "y", "c", "s", alpha=alpha)
