"""Effect sizes, their intervals, marginal means, within-subject error bars, the Holm family
without the tests that could not be computed, and letters beyond the alphabet, against R
(``tests/analysis/R/reference.R``: afex, emmeans, effectsize, stats, multcompView) on designs
other than those of the ANOVA references."""

import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab.analysis.effects import (
    eta2_partial_ci,
    hodges_lehmann,
    marginal_means,
    paired_effect,
    rank_biserial,
    within_subject_ci,
)
from glarelab.analysis.stats import (
    anova_residuals,
    group_letters,
    holm,
    normality,
    rm_anova,
    similarity_groups,
    wilcoxon_signed_rank,
)

from .test_stats import read_r

R_TOLERANCE = 1e-9  # the same method as R's: agreement to rounding
OPTIM_TOLERANCE = 1e-6  # effectsize's own limits: Nelder–Mead to 1e-9 on the probabilities
DESIGNS = ["es_3x5", "es_one_way_4", "es_2x2x3", "es_2x6_n3"]
FACTORS = {
    "es_3x5": ["a", "b"],
    "es_one_way_4": ["cue"],
    "es_2x2x3": ["p", "q", "r"],
    "es_2x6_n3": ["level", "method"],
}


def split(text):
    return [float(v) for v in str(text).split(";")]


@pytest.mark.parametrize("design", DESIGNS)
def test_generalized_eta2_and_the_eta2p_interval_match_afex_and_effectsize(design):
    data = read_r(f"effects_{design}.csv")
    theirs = read_r("effects_anova.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    ours = rm_anova(data, "y", FACTORS[design], "subject")
    assert [s.replace(" × ", ":") for s in ours["source"]] == list(theirs["source"])
    for column in ("F", "eta2_partial", "eta2_generalized"):
        assert_allclose(ours[column], theirs[column], rtol=R_TOLERANCE, err_msg=column)
    for row, (_, r) in zip(ours.itertuples(), theirs.iterrows(), strict=True):
        low, high = eta2_partial_ci(row.F, row.df1, row.df2)
        assert_allclose([low, high], [r["eta2p_ci_low"], r["eta2p_ci_high"]], atol=R_TOLERANCE)
        assert_allclose(
            [low, high], [r["effectsize_ci_low"], r["effectsize_ci_high"]], atol=OPTIM_TOLERANCE
        )


def test_generalized_eta2_is_far_below_partial_where_subjects_differ_much():
    """The issue's 3 × 5 case: η²p = .41 where η²G is near 0, because the subjects' own
    variance (in η²G's denominator) dwarfs the effect's."""
    rng = np.random.default_rng(3)
    subjects = np.repeat(np.arange(12), 15)
    cells = np.tile(np.arange(15), 12)
    y = 100 * rng.normal(size=12)[subjects] + 0.4 * (cells % 5) + rng.normal(0, 0.6, cells.size)
    data = pd.DataFrame({"s": subjects, "a": cells // 5, "b": cells % 5, "y": y})
    table = rm_anova(data, "y", ["a", "b"], "s").set_index("source")
    assert table.loc["b", "eta2_partial"] > 0.3
    assert table.loc["b", "eta2_generalized"] < 0.01


@pytest.mark.parametrize("design", DESIGNS)
def test_marginal_means_match_emmeans(design):
    data = read_r(f"effects_{design}.csv")
    theirs = read_r("effects_emmeans.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    ours = marginal_means(data, "y", FACTORS[design], "subject")
    assert list(ours["level"]) == list(theirs["level"])
    for column in ("emmean", "se", "df", "ci_low", "ci_high"):
        assert_allclose(ours[column], theirs[column], rtol=R_TOLERANCE, err_msg=column)


@pytest.mark.parametrize("design", DESIGNS)
def test_within_subject_intervals_and_residual_normality_match_r(design):
    data = read_r(f"effects_{design}.csv")
    theirs = read_r("effects_within_ci.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    ours = within_subject_ci(data, "y", FACTORS[design], "subject")
    cells = [":".join(map(str, row)) for row in ours[FACTORS[design]].to_numpy()]
    assert cells == list(theirs["cell"])
    for column in ("mean", "sem_within", "ci_half"):
        assert_allclose(ours[column], theirs[column], rtol=R_TOLERANCE, err_msg=column)
    test = normality(anova_residuals(data, "y", FACTORS[design], "subject"))
    # scipy and R both run Royston's swilk; they agree to about 1e-7 (single precision there)
    assert_allclose(test["W"], theirs["residuals_shapiro_W"].iloc[0], rtol=1e-6)
    assert_allclose(test["p"], theirs["residuals_shapiro_p"].iloc[0], rtol=1e-4)


def test_within_subject_intervals_are_narrower_than_between_where_subjects_differ():
    rng = np.random.default_rng(4)
    subjects = np.repeat(np.arange(10), 4)
    y = 50 * rng.normal(size=10)[subjects] + np.tile([0, 1, 2, 3], 10) + rng.normal(0, 0.5, 40)
    data = pd.DataFrame({"s": subjects, "c": np.tile(list("wxyz"), 10), "y": y})
    within = within_subject_ci(data, "y", ["c"], "s")
    between = data.groupby("c")["y"].sem().to_numpy()
    assert np.all(within["sem_within"].to_numpy() < between / 10)


@pytest.mark.parametrize("case", ["n5", "n12", "n40_small", "offset_1e6", "negative"])
def test_paired_effects_match_t_test_and_the_noncentral_t(case):
    row = read_r("effects_paired.csv").set_index("case").loc[case]
    ours = paired_effect(split(row["a"]), split(row["b"]))
    for column in ("mean_difference", "md_ci_low", "md_ci_high", "d_z"):
        # a 1e6 offset leaves ten digits of the differences: rounding at 1e-10 relative
        assert_allclose(ours[column], row[column], rtol=1e-8, err_msg=column)
    assert_allclose([ours["dz_ci_low"], ours["dz_ci_high"]], [row["dz_ci_low"], row["dz_ci_high"]],
                    rtol=1e-8)  # fmt: skip
    assert_allclose(ours["d_z"], row["effectsize_d"], rtol=1e-8)
    assert_allclose(
        [ours["dz_ci_low"], ours["dz_ci_high"]],
        [row["effectsize_ci_low"], row["effectsize_ci_high"]],
        atol=OPTIM_TOLERANCE,
    )


@pytest.mark.parametrize(
    "case",
    ["exact_n9", "exact_n25", "likert_ties_zeros", "likert_n30", "all_above", "differences"],
)
def test_rank_biserial_and_hodges_lehmann_match_effectsize_and_wilcox_test(case):
    row = read_r("effects_wilcoxon.csv").set_index("case").loc[case]
    x, mu = split(row["x"]), float(row["mu"])
    ours = rank_biserial(x, mu=mu)
    for column in ("r_rb", "rb_ci_low", "rb_ci_high"):
        assert_allclose(ours[column], row[column], rtol=R_TOLERANCE, err_msg=column)
    shift = hodges_lehmann(x, mu=mu)
    # R's estimate, also where its test is not exact (ties or zeros: uniroot, as here)
    assert_allclose(shift["hl_shift"] + mu, row["wilcox_estimate"], rtol=R_TOLERANCE)
    if row["exact"]:  # there it is the Walsh median of x
        assert_allclose(shift["hl_shift"], row["walsh_median"], rtol=R_TOLERANCE, atol=1e-12)


def test_the_holm_family_holds_only_the_tests_r_could_compute():
    theirs = read_r("holm_family.csv")
    p = []
    for ratings in theirs["ratings"]:
        values = split(ratings)
        p.append(
            wilcoxon_signed_rank(values, mu=4)["p"] if np.any(np.array(values) != 4) else np.nan
        )
    assert_allclose(p, theirs["p"], rtol=R_TOLERANCE)  # NaN where R has NA
    assert_allclose(holm(p, missing="omit"), theirs["p_holm"], rtol=R_TOLERANCE)
    with pytest.raises(ValueError, match="pvalues must be numbers"):
        holm(p)


def test_the_issues_questionnaire_keeps_rs_decision():
    """Glare Appearance all 4 and Overall 7 5 3 6 6 6 6 4: R's Holm p for Overall is .0385."""
    overall = wilcoxon_signed_rank([7, 5, 3, 6, 6, 6, 6, 4], mu=4)["p"]
    adjusted = holm([np.nan, overall], missing="omit")
    assert np.isnan(adjusted[0])
    assert_allclose(adjusted[1], 0.038506040175992767, rtol=R_TOLERANCE)


def test_similarity_groups_beyond_the_alphabet_match_multcompview():
    pairs = read_r("letters_27_pairs.csv")
    theirs = read_r("letters_27.csv").set_index("level")["letters"].to_dict()
    levels = sorted(set(pairs["a"]) | set(pairs["b"]))
    means = {level: -i for i, level in enumerate(levels)}  # decreasing in R's level order
    ours = similarity_groups(
        means, {(r.a, r.b): r.p_adjusted for r in pairs.itertuples()}
    )  # fmt: skip

    def groups(display):
        names = {name for v in display.values() for name in v}
        return {frozenset(k for k, v in display.items() if name in v) for name in names}

    assert groups(ours) == groups(theirs)
    assert len(groups(ours)) == 27
    # the same names (a … z, then A); multcompView orders its columns differently
    assert {n for v in ours.values() for n in v} == {n for v in theirs.values() for n in v}


@given(st.integers(0, 400))
@settings(max_examples=60, deadline=None)
def test_group_letters_are_distinct_and_none_is_a_prefix_issue(count):
    names = group_letters(count)
    assert len(names) == len(set(names)) == count
    assert names[:26] == list("abcdefghijklmnopqrstuvwxyz")[: min(count, 26)]


def test_importing_the_analysis_leaves_numpys_print_options_as_they_were():
    code = (
        "import numpy as np; before = np.get_printoptions(); import glarelab.analysis.report; "
        "import glarelab.analysis.stimulus_figures; assert np.get_printoptions() == before, "
        "np.get_printoptions()"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr


def test_report_csvs_hold_every_digit_whatever_numpys_print_options(tmp_path):
    from glarelab.analysis.export import csv_text

    table = pd.DataFrame({"F": [20.077025396150553, 1 / 3, 1e-300, 12345678.901234567]})
    before = np.get_printoptions()
    np.set_printoptions(legacy="1.13")  # what colour-science sets
    try:
        (tmp_path / "t.csv").write_text(csv_text(table))
    finally:
        np.set_printoptions(**before)
    lines = (tmp_path / "t.csv").read_text().split()[1:]
    assert [float(v) for v in lines] == table["F"].tolist()
    assert lines[0] == "20.077025396150553"


# R 4.2: wilcox.test(x, conf.int = TRUE, conf.level = 0.95): the interval, the level R reports
# (lowered where the sample cannot reach 95 %) and the estimate
R_SMALL_SAMPLE_LEVELS = [
    ([0.4], 0.4, 0.4, 0.0, 0.4),
    ([0.3, 1.2], 0.3, 1.2, 0.5, 0.75),
    ([1.0, 2.0, 3.0], 1.0, 3.0, 0.75, 2.0),
    ([0.2, 1.1, -0.4, 0.9], -0.4, 1.1, 0.88, 0.45),
    ([1.3, 0.2, 2.1, 0.7, 1.9, -0.3], -0.3, 2.1, 0.95, 1.0),
]


@pytest.mark.parametrize("x, low, high, level, estimate", R_SMALL_SAMPLE_LEVELS)
def test_hodges_lehmann_reports_the_level_r_reaches_in_small_samples(
    x, low, high, level, estimate
):
    """Ratings 5, 6, 7 about a midpoint of 4 reach 75 %, not 95 %: an interval called 95 %
    there excludes 0 beside a signed-rank test that is not significant."""
    result = hodges_lehmann(x)
    assert_allclose(
        [result["hl_ci_low"], result["hl_ci_high"], result["hl_confidence"], result["hl_shift"]],
        [low, high, level, estimate],
        atol=1e-12,
    )


@pytest.mark.parametrize(
    ("dv_values", "pattern"),
    [
        (["1", "2", "3", "4"], "real numbers"),  # was an interval from text
        ([True, False, True, True], "real numbers"),
        ([1.0, np.nan, 3.0, 4.0], "NaN"),
    ],
)
def test_a_within_subject_interval_refuses_a_dv_that_is_not_numbers(dv_values, pattern):
    from glarelab.analysis.effects import within_subject_ci

    data = pd.DataFrame({"s": [1, 1, 2, 2], "c": ["x", "y"] * 2, "v": dv_values})
    with pytest.raises(ValueError, match=pattern):
        within_subject_ci(data, "v", ["c"], "s")


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda f: f(-1.0, 2, 20), "f_value"),
        (lambda f: f(5.0, 0, 20), "df1"),
        (lambda f: f(5.0, 2, float("inf")), "df2"),
        (lambda f: f("5", 2, 20), "f_value"),
    ],
)
def test_the_eta_interval_names_the_argument_it_refuses(call, name):
    from glarelab.analysis.effects import eta2_partial_ci

    with pytest.raises(ValueError, match=name):
        call(eta2_partial_ci)


@pytest.mark.parametrize("flag", ["no", 0, None])
def test_a_dz_interval_flag_that_is_no_bool_is_refused(flag):
    """``dz_interval='no'`` is true to ``if``: the interval was computed anyway."""
    with pytest.raises(ValueError, match=r"^paired_effect: dz_interval must be True or False"):
        paired_effect([1.0, 2.0, 4.0], [0.0, 1.5, 2.0], dz_interval=flag)


X_MASKED = np.ma.masked_array([1.5, -0.3, 2.2, 0.8, 3.1, -1.2, 0.4, 2.9], [0, 0, 0, 0, 1, 0, 0, 1])


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: hodges_lehmann(X_MASKED), "hodges_lehmann: x must be a plain array"),
        (lambda: rank_biserial(X_MASKED), "rank_biserial: x must be a plain array"),
        (
            lambda: paired_effect(
                np.ma.masked_array([1.0, 2, 3, 40], [0, 0, 0, 1]), [1.5, 1, 2, 3]
            ),
            "paired_effect: a must be a plain array",
        ),
        (
            lambda: paired_effect([1.0, 2, 3], np.ma.masked_array([1.0, 2, 4], [1, 0, 0])),
            "b must be a plain",
        ),
        (
            lambda: rank_biserial(["1.5", "-0.3", "2.2"]),
            r"rank_biserial: x must hold real numbers.*'1.5'",
        ),
        (lambda: rank_biserial([True, True, False, True]), r"x must hold real numbers.*True"),
        (lambda: hodges_lehmann(["1", "2", "3"]), r"hodges_lehmann: x must hold real numbers"),
        (
            lambda: rank_biserial("abc"),
            r"rank_biserial: x must be a sequence of numbers; got the string 'abc'",
        ),
        (
            lambda: paired_effect([1.0, 2.0, 3.0], [True, False, True]),
            r"paired_effect: b must hold real",
        ),
    ],
)
def test_the_effect_sizes_refuse_masked_arrays_strings_and_bools(call, pattern):
    """A masked array's hidden values were used (hodges_lehmann gave 1.225 for 0.6) and
    strings and bools were read as numbers: they are refused as the t-tests refuse them."""
    with pytest.raises(TypeError, match=pattern):
        call()


@pytest.mark.parametrize("mu", ["4", True, float("nan")])
def test_rank_biserial_and_hodges_lehmann_refuse_a_mu_that_is_not_a_number(mu):
    for f in (rank_biserial, hodges_lehmann):
        with pytest.raises(ValueError, match=f"{f.__name__}: mu must be a finite number"):
            f([1.0, 2.0, 3.0], mu=mu)


def test_paired_effect_without_its_pairs_is_refused_not_a_one_sample_effect():
    # paired_effect(a, None) returned the one-sample d of a against 0
    with pytest.raises(TypeError, match=r"^paired_effect: b must be the values paired with a"):
        paired_effect([1.2, 2.3, 3.1, 4.8], None)


@pytest.mark.parametrize("confidence", ["0.9", True, None, [0.9]])
def test_a_confidence_that_is_no_number_is_refused_naming_it(confidence):
    with pytest.raises(ValueError, match=r"^eta2_partial_ci: confidence must lie strictly"):
        eta2_partial_ci(5.0, 1, 10, confidence=confidence)
