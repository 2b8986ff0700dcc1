"""holm, holm_confidence and similarity_groups at their boundary: p-values and levels that are
not numbers (strings, bools) or out of range are refused naming the argument, never read as
numbers; valid families give finite adjusted values in [0, 1]."""

import math
import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.analysis.stats import corrected_p, holm, holm_confidence, similarity_groups

SETTINGS = settings(max_examples=30, deadline=None)
P = st.floats(0.0, 1.0)
NOT_A_P = st.one_of(
    st.text(max_size=4),
    st.booleans(),
    st.none(),
    st.floats(1.0, 1e300, exclude_min=True),
    st.floats(max_value=0.0, exclude_max=True),
    st.sampled_from([math.inf, -math.inf]),
    st.complex_numbers(allow_nan=False, allow_infinity=False, min_magnitude=1e-3),
)


@SETTINGS
@given(ps=st.lists(P, min_size=1, max_size=6), bad=NOT_A_P, at=st.integers(0, 6))
def test_holm_refuses_a_p_value_that_is_not_one_naming_pvalues(ps, bad, at):
    ps.insert(min(at, len(ps)), bad)
    for function in (holm, holm_confidence):
        with pytest.raises(
            (ValueError, TypeError), match=r"^holm(_confidence)?: pvalues must be"
        ) as raised:
            function(ps)
        assert "\n" not in str(raised.value)


@pytest.mark.parametrize("pvalues", [["0.01", "0.5"], [True, False], 0.1, [[0.1, 0.2]], "0.1"])
def test_holm_refuses_strings_bools_scalars_and_tables(pvalues):
    with pytest.raises(TypeError, match=r"^holm: pvalues must be"):
        holm(pvalues)


@SETTINGS
@given(ps=st.lists(P, min_size=0, max_size=8))
def test_holm_of_valid_p_values_is_finite_in_the_unit_interval(ps):
    adjusted = holm(ps)
    assert adjusted.shape == (len(ps),)
    assert np.isfinite(adjusted).all() and ((adjusted >= np.array(ps)) & (adjusted <= 1)).all()


NOT_AN_ALPHA = st.one_of(
    st.floats(1.0, 1e300),
    st.floats(max_value=0.0),
    st.sampled_from([math.nan, math.inf, True, False, "0.05", None]),
)


@SETTINGS
@given(data=st.data())
def test_similarity_groups_refuses_bad_arguments_naming_them(data):
    means = {"A": 1.0, "B": 2.0, "C": 3.0}
    p_adjusted = {("A", "B"): 0.5, ("A", "C"): 0.01, ("B", "C"): 0.5}
    name = data.draw(st.sampled_from(["alpha", "means", "p_adjusted", "pair"]), label="argument")
    alpha = 0.05
    if name == "alpha":
        alpha = data.draw(NOT_AN_ALPHA, label="alpha")
    elif name == "means":
        means["B"] = data.draw(
            st.one_of(st.text(max_size=3), st.booleans(), st.none(),
                      st.sampled_from([math.nan, math.inf])),
            label="mean",
        )  # fmt: skip
    elif name == "p_adjusted":
        p_adjusted[("A", "C")] = data.draw(NOT_A_P, label="p")
    else:
        p_adjusted[data.draw(st.sampled_from([("A", "D"), "AB", ("A",), ("A", "B", "C")]))] = 0.01
        name = "p_adjusted"
    with pytest.raises((ValueError, TypeError), match=rf"^similarity_groups: {name}"):
        similarity_groups(means, p_adjusted, alpha=alpha)


@pytest.mark.parametrize("alpha", [2, 0, 1.0, math.nan])
def test_similarity_groups_refuses_an_alpha_outside_the_unit_interval(alpha):
    # α = 2 made every pair significant: each level got a letter of its own
    with pytest.raises(ValueError, match=r"alpha must lie strictly between 0 and 1; got"):
        similarity_groups({"A": 1, "B": 2}, {("A", "B"): 0.5}, alpha=alpha)


@SETTINGS
@given(
    means=st.lists(st.floats(-1e9, 1e9), min_size=2, max_size=5),
    ps=st.lists(st.one_of(P, st.just(math.nan)), min_size=10, max_size=10),
    alpha=st.floats(1e-6, 1.0, exclude_max=True),
)
def test_similarity_groups_gives_every_level_a_letter(means, ps, alpha):
    levels = {f"L{i}": m for i, m in enumerate(means)}
    pairs = [(a, b) for i, a in enumerate(levels) for b in list(levels)[i + 1 :]]
    letters = similarity_groups(
        levels, dict(zip(pairs, ps, strict=False)), alpha=alpha, missing="omit"
    )
    assert set(letters) == set(levels) and all(letters.values())


@SETTINGS
@given(means=st.lists(st.floats(-1e9, 1e9), min_size=2, max_size=5), data=st.data())
def test_similarity_groups_refuses_a_nan_p_value_naming_its_pair(means, data):
    # a NaN p-value read as "not different" put two levels in one group without a word
    levels = {f"L{i}": m for i, m in enumerate(means)}
    pairs = [(a, b) for i, a in enumerate(levels) for b in list(levels)[i + 1 :]]
    p_adjusted = dict.fromkeys(pairs, 0.5)
    at = data.draw(st.integers(0, len(pairs) - 1), label="at")
    p_adjusted[pairs[at]] = math.nan
    with pytest.raises(
        ValueError,
        match=rf"^similarity_groups: p_adjusted is NaN for {re.escape(repr(pairs[at]))} "
        rf"\(position {at}\);.*missing='omit'",
    ):
        similarity_groups(levels, p_adjusted)
    assert set(similarity_groups(levels, p_adjusted, missing="omit")) == set(levels)


@pytest.mark.parametrize("missing", ["drop", None, True])
def test_similarity_groups_refuses_an_unknown_missing(missing):
    with pytest.raises(ValueError, match=r"^similarity_groups: missing must be 'raise' or"):
        similarity_groups({"A": 1, "B": 2}, {("A", "B"): 0.5}, missing=missing)


@pytest.mark.parametrize(
    ("row", "error", "named"),
    [
        ({"p": 0.01, "df1": 2.0}, TypeError, "corrected_p: row must be a row of rm_anova's table"),
        (pd.Series({"p": 0.01}), ValueError, "corrected_p: row lacks df1, eps_gg"),
        (pd.Series({"df1": 3.0, "eps_gg": 0.5}), ValueError, "corrected_p: row lacks p_gg"),
    ],
)
def test_corrected_p_of_a_row_that_is_not_rm_anovas_is_refused(row, error, named):
    # a dict, or a row without its columns, ended in KeyError 'df1'
    with pytest.raises(error, match=re.escape(named)):
        corrected_p(row)


@pytest.mark.parametrize(
    ("means", "p_adjusted", "error", "match"),
    [
        # a pair left out was read as "not different": every level shared one letter
        ({"a": 1.0, "b": 2.0, "c": 3.0}, {("a", "b"): 0.5}, ValueError,
         r"p_adjusted has no p-value for 2 pair\(s\) of levels, e\.g\. \('a', 'c'\)"),
        ({"a": 1.0, "b": 2.0}, {("a", "b"): 0.5, ("a", "a"): 0.01}, ValueError,
         r"p_adjusted has a level paired with itself: \('a', 'a'\)"),
        ({"a": 1.0, "b": 2.0}, {("a", "b"): 0.5, ("b", "a"): 0.001}, ValueError,
         r"p_adjusted has the pair \('a', 'b'\) twice \(also as \('b', 'a'\)\)"),
        ([1.0, 2.0], {(0, 1): 0.5}, TypeError, r"means must be a dict, got list"),
        ({"a": 1.0, "b": 2.0}, [0.5], TypeError, r"p_adjusted must be a dict, got list"),
        ({}, {}, ValueError, r"means must hold at least one level"),
    ],
)  # fmt: skip
def test_similarity_groups_refuses_pair_tables_that_cannot_be_read_one_way(
    means, p_adjusted, error, match
):
    with pytest.raises(error, match=rf"^similarity_groups: {match}"):
        similarity_groups(means, p_adjusted)


def test_similarity_groups_leaves_absent_pairs_out_only_when_asked():
    letters = similarity_groups({"a": 1.0, "b": 2.0, "c": 3.0}, {("a", "c"): 0.01}, missing="omit")
    assert letters == {"c": "a", "b": "ab", "a": "b"}


def test_rm_anova_refuses_rows_without_their_subject_and_what_is_no_table():
    from glarelab.analysis.stats import rm_anova

    long = pd.DataFrame(
        {"subject": [0, 0, 1, 1, np.nan, np.nan], "level": [0, 1] * 3, "y": [1.0, 2, 3, 5, 4, 4]}
    )
    with pytest.raises(ValueError, match=r"^rm_anova: column 'subject' has no value in 2 row"):
        rm_anova(long, "y", "level", "subject")
    with pytest.raises(TypeError, match=r"^rm_anova: df must be a pandas DataFrame .*got list$"):
        rm_anova(long.to_dict("records"), "y", "level", "subject")
