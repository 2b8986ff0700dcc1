"""Statistics against R (the reference: values stored in tests/analysis/R by reference.R, made
with R 4.2, car, afex and multcompView), pingouin (an independent implementation) and
analytic properties."""

import itertools
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pingouin as pg  # test-only dependency: the independent implementation
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import stats as sps

from glarelab.analysis.apa import apa_anova, apa_F, apa_p, apa_t
from glarelab.analysis.stats import (
    ROUNDING,
    _no_variance,
    holm,
    pairwise_tests,
    rm_anova,
    similarity_groups,
    ttest_one_sample,
    ttest_paired,
    ttest_welch,
    wilcoxon_signed_rank,
)

R_FOLDER = Path(__file__).parent / "R"
R_TOLERANCE = 1e-11  # relative; the measured differences are below 1e-13


def read_r(name):
    """A table written by reference.R (its comment lines name the R version and packages)."""
    return pd.read_csv(R_FOLDER / name, comment="#")


def numbers(text):
    return [float(v) for v in text.split(";")]


R_ANOVA = read_r("anova_results.csv")
R_WILCOXON = read_r("wilcoxon.csv")
R_TTESTS = read_r("ttests.csv")

COLUMNS = ["df1", "df2", "F", "p", "eps_gg", "p_gg"]


def random_design(levels, n, seed):
    rng = np.random.default_rng(seed)
    names = [f"f{i}" for i in range(len(levels))]
    rows = []
    for s in range(n):
        subject = rng.normal(0, 1)
        slopes = rng.normal(0.3, 0.3, len(levels))
        for cell in itertools.product(*[range(k) for k in levels]):
            noise_sd = 1 + 0.6 * cell[0]  # unequal variances: sphericity violated
            value = subject + sum(b * c for b, c in zip(slopes, cell, strict=True))
            rows.append(
                {
                    "s": f"S{s}",
                    **{nm: f"L{c}" for nm, c in zip(names, cell, strict=True)},
                    "v": value + rng.normal(0, noise_sd),
                }
            )
    return pd.DataFrame(rows), names


def pingouin_table(df, names):
    table = pg.rm_anova(
        df, dv="v", within=names if len(names) > 1 else names[0], subject="s", correction=True
    )
    table = table[table["Source"] != "Error"]
    n = len(table)
    # pingouin drops columns that are all NaN (every effect with one df): epsilon 1, p as is
    eps = table["eps"].fillna(1.0) if "eps" in table else pd.Series([1.0] * n, index=table.index)
    p_gg = table["p_GG_corr"].fillna(table["p_unc"]) if "p_GG_corr" in table else table["p_unc"]
    return pd.DataFrame(
        {
            "df1": table["ddof1"].to_numpy(float),
            "df2": table["ddof2"].to_numpy(float),
            "F": table["F"].to_numpy(float),
            "p": table["p_unc"].to_numpy(float),
            "eps_gg": eps.to_numpy(float),
            "p_gg": p_gg.to_numpy(float),
        }
    )


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("levels", [(3,), (6,), (2, 3), (6, 2), (3, 4)])
def test_rm_anova_matches_pingouin(levels, seed):
    df, names = random_design(levels, n=10, seed=seed)
    ours = rm_anova(df, "v", names, "s")
    assert_allclose(
        ours[COLUMNS].to_numpy(float), pingouin_table(df, names).to_numpy(float), rtol=1e-6
    )


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("levels", [(5,), (3, 4)])
def test_mauchly_matches_pingouin_for_main_effects_and_interactions(levels, seed):
    df, names = random_design(levels, n=12, seed=seed)
    ours = rm_anova(df, "v", names, "s")
    theirs = pg.rm_anova(
        df, dv="v", within=names if len(names) > 1 else names[0], subject="s", correction=True
    )
    theirs = theirs[theirs["Source"] != "Error"]
    assert_allclose(ours["mauchly_W"], theirs["W_spher"], rtol=1e-6)
    assert_allclose(ours["mauchly_p"], theirs["p_spher"], rtol=1e-6)


@pytest.mark.parametrize("seed", range(3))
def test_three_way_designs_against_pingouin_on_collapsed_data(seed):
    # In a full within design, a main effect's F, df and epsilon equal those of the one-way
    # ANOVA on the subject means averaged over the other factors; a two-way interaction's
    # equal those of the two-way ANOVA averaged over the third (the contrasts are the same).
    df, names = random_design((3, 4, 2), n=9, seed=seed)
    ours = rm_anova(df, "v", names, "s").set_index("source")
    assert list(ours.index) == ["f0", "f1", "f2", "f0 × f1", "f0 × f2", "f1 × f2", "f0 × f1 × f2"]
    for factor in names:
        collapsed = df.groupby(["s", factor], as_index=False)["v"].mean()
        theirs = pingouin_table(collapsed, [factor]).iloc[0]
        assert_allclose(
            ours.loc[factor, COLUMNS].to_numpy(float), theirs.to_numpy(float), rtol=1e-6
        )
    for a, b in itertools.combinations(names, 2):
        collapsed = df.groupby(["s", a, b], as_index=False)["v"].mean()
        theirs = pingouin_table(collapsed, [a, b]).iloc[2]
        assert_allclose(
            ours.loc[f"{a} × {b}", COLUMNS].to_numpy(float), theirs.to_numpy(float), rtol=1e-6
        )
    # the three-way interaction: epsilon lies between its bounds, and for F > 1 the corrected
    # p is larger (for F < 1 fewer degrees of freedom can make it smaller)
    last = ours.loc["f0 × f1 × f2"]
    assert 1 / last["df1"] - 1e-12 <= last["eps_gg"] <= 1 + 1e-12
    assert last["F"] < 1 or last["p_gg"] >= last["p"] - 1e-12


def test_rm_anova_on_pingouins_example_data():
    data = pg.read_dataset("rm_anova2")
    data = data.groupby(["Subject", "Time", "Metric"], as_index=False)["Performance"].mean()
    ours = rm_anova(data, "Performance", ["Time", "Metric"], "Subject")
    theirs = pg.rm_anova(
        data, dv="Performance", within=["Time", "Metric"], subject="Subject", correction=True
    )
    assert_allclose(ours["F"], theirs["F"], rtol=1e-6)
    assert_allclose(ours["eps_gg"], theirs["eps"].fillna(1.0), rtol=1e-6)
    assert_allclose(ours["p_gg"], theirs["p_GG_corr"].fillna(theirs["p_unc"]), rtol=1e-6)


def test_rm_anova_refuses_unbalanced_designs():
    df, names = random_design((3,), n=5, seed=0)
    with pytest.raises(ValueError, match=r"subject 'S2' has no 'v' at \{'f0': 'L1'\}"):
        rm_anova(df.drop(index=7), "v", names, "s")
    with pytest.raises(
        ValueError, match="exactly one 'v' per subject and cell; subject 'S0' has 2"
    ):
        rm_anova(pd.concat([df, df.iloc[[0]]]), "v", names, "s")
    with pytest.raises(ValueError, match=r"column\(s\) \['w'\] not in the data"):
        rm_anova(df, "w", names, "s")


def test_holm_by_hand():
    # hand calculation: sorted .01, .03, .04 → ×3, ×2, ×1 = .03, .06, .04 → monotone: .03, .06, .06
    assert_allclose(holm([0.04, 0.01, 0.03]), [0.06, 0.03, 0.06])
    assert_allclose(holm([0.5, 0.001]), [0.5, 0.002])
    with pytest.raises(ValueError, match=r"in \[0, 1\]"):
        holm([0.5, 1.5])


def test_t_tests_against_pingouin():
    rng = np.random.default_rng(3)
    a, b = rng.normal(0, 1, 10), rng.normal(0.8, 2.5, 10)
    paired = ttest_paired(a, b)
    theirs = pg.ttest(a, b, paired=True)
    assert_allclose(
        [paired["t"], paired["df"], paired["p"]],
        [theirs["T"].iloc[0], theirs["dof"].iloc[0], theirs["p_val"].iloc[0]],
        rtol=1e-9,
    )
    welch = ttest_welch(a, b)
    theirs = pg.ttest(a, b, correction=True)
    assert_allclose(
        [welch["t"], welch["df"], welch["p"]],
        [theirs["T"].iloc[0], theirs["dof"].iloc[0], theirs["p_val"].iloc[0]],
        rtol=1e-9,
    )


def test_similarity_groups_recover_a_known_grouping():
    # levels A, B close; C, D close; E apart: expect {A, B}, {C, D}, {E}
    means = {"A": 1.0, "B": 1.1, "C": 2.0, "D": 2.1, "E": 3.5}
    levels = list(means)
    p = {}
    for x, y in itertools.combinations(levels, 2):
        same = {x, y} <= {"A", "B"} or {x, y} <= {"C", "D"}
        p[(x, y)] = 0.4 if same else 0.001
    groups = similarity_groups(means, p)
    assert groups["A"] == groups["B"] and groups["C"] == groups["D"]
    assert len({groups["A"], groups["C"], groups["E"]}) == 3
    assert groups["E"] == "a"  # highest mean first
    # overlapping groups: A~B, B~C, A≠C
    assert similarity_groups(
        {"A": 1, "B": 2, "C": 3}, {("A", "B"): 0.3, ("B", "C"): 0.3, ("A", "C"): 0.01}
    ) == {"C": "a", "B": "ab", "A": "b"}


def test_pairwise_tests_are_holm_adjusted():
    df, _ = random_design((4,), n=10, seed=1)
    table = pairwise_tests(df, "v", "f0", "s")
    assert len(table) == 6
    assert_allclose(table["p_holm"], holm(table["p"]))


def test_apa_strings():
    assert apa_F(5, 45, 23.684, 1e-6) == "F(5, 45) = 23.68, p < .001"  # Yoshida §5
    assert apa_F(1, 9, 1.64, 0.2325) == "F(1, 9) = 1.64, p = .233"
    assert apa_F(2.5, 22.51, 3.0, 0.07) == "F(2.50, 22.51) = 3.00, p = .070"
    assert apa_t(14, 1.714, 0.05) == "t(14) = 1.71, p = .050"


# ---------------------------------------------------------------------------------- against R


def test_every_stored_r_output_names_r_and_its_packages():
    outputs = sorted(R_FOLDER.glob("*.csv"))
    # reference.R: 10 + 4 designs and their results, 13 more; real_data.R: 12
    assert len(outputs) == 41
    for path in outputs:
        first, second = path.read_text().splitlines()[:2]
        script = "real_data" if path.name.startswith("real_") else "reference"
        assert re.fullmatch(
            rf"# made by tests/analysis/R/{script}\.R with R version \d+\.\d+\.\d+.*", first
        )
        assert re.fullmatch(
            r"# packages: car [\d.-]+, afex [\d.-]+, multcompView [\d.-]+, stats [\d.]+", second
        )


@pytest.mark.parametrize("design", list(dict.fromkeys(R_ANOVA["design"])))
def test_rm_anova_matches_r(design):
    theirs = R_ANOVA[R_ANOVA["design"] == design].reset_index(drop=True)
    data = read_r(f"anova_{design}.csv")
    within = theirs["within"].iloc[0].split(";")
    ours = rm_anova(data, "y", within, theirs["subject"].iloc[0])
    assert list(ours["source"]) == [s.replace(":", " × ") for s in theirs["source"]]
    for column in ("df1", "df2", "F", "p", "eta2_partial"):
        assert_allclose(ours[column], theirs[column], rtol=R_TOLERANCE, err_msg=column)
    one_df = theirs["df1"] == 1
    estimated = ~theirs["singular"] & ~one_df
    # where R estimates sphericity: GG, HF (capped at 1 as car does for its p-value), Mauchly
    theirs = theirs.assign(eps_hf=np.minimum(1.0, theirs["eps_hf_uncapped"]))
    for column in ("eps_gg", "p_gg", "eps_hf", "p_hf", "mauchly_W", "mauchly_p"):
        assert_allclose(
            ours.loc[estimated, column],
            theirs.loc[estimated, column],
            rtol=R_TOLERANCE,
            err_msg=column,
        )
    assert (ours.loc[estimated, "sphericity"] == "estimated").all()
    # one df: sphericity holds (R gives no correction and no Mauchly test)
    assert (ours.loc[one_df, ["eps_gg", "eps_hf"]] == 1.0).all().all()
    assert_allclose(ours.loc[one_df, "p_gg"], theirs.loc[one_df, "p"], rtol=R_TOLERANCE)
    assert_allclose(ours.loc[one_df, "p_hf"], theirs.loc[one_df, "p"], rtol=R_TOLERANCE)
    assert ours.loc[one_df, ["mauchly_W", "mauchly_p"]].isna().all().all()
    # a singular error SSP matrix: R estimates nothing, and neither do we
    singular = theirs["singular"]
    columns = ["eps_gg", "p_gg", "eps_hf", "p_hf", "mauchly_W", "mauchly_p"]
    assert ours.loc[singular, columns].isna().all().all()
    assert ours.loc[singular, "sphericity"].str.startswith("not estimable: ").all()


def test_r_reference_covers_the_cases_of_the_issue():
    by_design = R_ANOVA.groupby("design")
    assert by_design["within"].first().str.count(";").max() == 2  # one to three within factors
    assert (R_ANOVA["eps_hf_uncapped"] > 1).sum() >= 3  # HF capped at 1
    assert (R_ANOVA["eps_hf_uncapped"] < 1).sum() >= 10
    assert R_ANOVA.loc[R_ANOVA["design"] == "spencer_12x2", "singular"].sum() == 2
    assert by_design["within"].first()["formula_names"] == "C;Q"


def test_spencers_shape_says_why_sphericity_is_not_estimable():
    ours = rm_anova(
        read_r("anova_spencer_12x2.csv"), "y", ["glare_level", "context"], "subject"
    ).set_index("source")
    reason = "not estimable: 8 subjects for 11 df, needs at least 12"
    assert ours.loc["glare_level", "sphericity"] == reason
    assert ours.loc["glare_level × context", "sphericity"] == reason
    assert ours.loc["context", "sphericity"] == "holds: 1 df"
    theirs = R_ANOVA[R_ANOVA["design"] == "spencer_12x2"].set_index("source")
    strings = dict(zip(ours.index, apa_anova(ours.reset_index(), correction="GG"), strict=True))
    level = theirs.loc["glare_level"]
    lower = sps.f.sf(level["F"], 1, level["df2"] / level["df1"])  # the lower bound ε = 1/11
    assert strings["glare_level"] == (
        f"{apa_F(1, level['df2'] / level['df1'], level['F'], lower)} (lower-bound corrected; "
        f"sphericity {reason})"
    )
    assert "nan" not in " ".join(strings.values())


@pytest.mark.parametrize("correction", ["GG", "HF"])
def test_apa_anova_prints_rs_corrected_tests(correction):
    theirs = R_ANOVA[(R_ANOVA["design"] == "yoshida_6x2")].reset_index(drop=True)
    ours = rm_anova(read_r("anova_yoshida_6x2.csv"), "y", ["L_disk", "method"], "subject")
    eps = theirs["eps_gg"] if correction == "GG" else np.minimum(1, theirs["eps_hf_uncapped"])
    p = theirs["p_gg"] if correction == "GG" else theirs["p_hf"]
    expected = [
        apa_F(r.df1, r.df2, r.F, r.p)
        if r.df1 == 1
        else apa_F(r.df1 * e, r.df2 * e, r.F, corrected)
        for r, e, corrected in zip(theirs.itertuples(), eps, p, strict=True)
    ]
    assert apa_anova(ours, correction=correction) == expected
    assert apa_anova(ours, correction="none") == [
        apa_F(r.df1, r.df2, r.F, r.p) for r in theirs.itertuples()
    ]
    with pytest.raises(ValueError, match=r"correction must be one of none, GG, HF, LB; got 'gg'"):
        apa_anova(ours, correction="gg")


@pytest.mark.parametrize("case", R_WILCOXON["case"])
def test_wilcoxon_matches_rs_default(case):
    theirs = R_WILCOXON.set_index("case").loc[case]
    ours = wilcoxon_signed_rank(numbers(theirs["x"]), mu=float(theirs["mu"]))
    assert ours["V"] == theirs["V"]  # R's statistic: the positive ranks' sum
    assert_allclose(ours["p"], theirs["p"], rtol=R_TOLERANCE)
    r_method = {
        "Wilcoxon signed rank exact test": "exact",
        "Wilcoxon signed rank test with continuity correction": "normal, continuity-corrected",
    }
    assert ours["method"] == r_method[theirs["method"]]


def test_wilcoxon_reference_covers_exact_normal_ties_and_zeros():
    methods = R_WILCOXON.set_index("case")["method"]
    assert methods["exact_n49"].endswith("exact test")  # n < 50: exact
    assert methods["normal_n50"].endswith("continuity correction")  # n = 50: normal
    assert methods["ties"].endswith("continuity correction")
    assert methods["zeros"].endswith("continuity correction")
    assert methods["decimal_not_tied"].endswith("exact test")  # 4.1 - 4 != 4 - 3.9 in binary


@pytest.mark.parametrize("case", R_TTESTS["case"])
def test_t_tests_match_r(case):
    theirs = R_TTESTS.set_index("case").loc[case]
    a, b = numbers(theirs["a"]), numbers(theirs["b"])
    for name, ours in (("paired", ttest_paired(a, b)), ("welch", ttest_welch(a, b))):
        assert_allclose(
            [ours["t"], ours["df"], ours["p"]],
            [theirs[f"{name}_t"], theirs[f"{name}_df"], theirs[f"{name}_p"]],
            rtol=R_TOLERANCE,
        )
    welch = ttest_welch(a, b)  # the one-sided test as the Yoshida analysis computes it
    assert_allclose(sps.t.sf(welch["t"], welch["df"]), theirs["welch_p_greater"], rtol=R_TOLERANCE)


def test_pairwise_tests_holm_and_letters_match_r():
    theirs = read_r("pairwise_results.csv")
    ours = pairwise_tests(read_r("pairwise_data.csv"), "y", "level", "subject")
    assert list(zip(ours["a"], ours["b"], strict=True)) == list(
        zip(theirs["a"], theirs["b"], strict=True)
    )
    for column in ("t", "df", "p", "p_holm"):
        assert_allclose(ours[column], theirs[column], rtol=R_TOLERANCE, err_msg=column)
    means = read_r("pairwise_data.csv").groupby("level")["y"].mean().to_dict()
    letters = similarity_groups(means, {(r.a, r.b): r.p_holm for r in ours.itertuples()})
    r_letters = dict(zip(theirs["a"], theirs["letters_a"], strict=True)) | dict(
        zip(theirs["b"], theirs["letters_b"], strict=True)
    )

    def groups(display):  # the letters' names differ; the groups they define must not
        return {frozenset(k for k, v in display.items() if letter in v) for letter in "abcde"} - {
            frozenset()
        }

    assert groups(letters) == groups(r_letters)
    assert len(groups(letters)) == 3


def test_p_values_print_as_apa_including_rs_near_one():
    no_difference = R_TTESTS.set_index("case").loc["no_difference"]
    assert no_difference["paired_p"] >= 0.9995 and no_difference["welch_p"] >= 0.9995
    assert apa_p(no_difference["paired_p"]) == "p > .999"
    assert (
        apa_t(7, no_difference["paired_t"], no_difference["paired_p"]) == "t(7) = 0.00, p > .999"
    )
    symmetric = R_WILCOXON.set_index("case").loc["symmetric_p1"]
    assert symmetric["p"] == 1.0 and apa_p(symmetric["p"]) == "p > .999"
    assert [apa_p(p) for p in (0.9995, 0.99949, 0.0341, 0.001, 0.000999, 0.0)] == [
        "p > .999",
        "p = .999",
        "p = .034",
        "p = .001",
        "p < .001",
        "p < .001",
    ]
    for bad, shown in (
        (float("nan"), "nan"),
        (np.float64("nan"), "nan"),
        (-0.01, "-0.01"),
        (1.01, "1.01"),
        (float("inf"), "inf"),
        ("n.s.", "'n.s.'"),
    ):
        with pytest.raises(
            ValueError, match=re.escape(f"apa_p: p must be a number in [0, 1]; got {shown}")
        ):
            apa_p(bad)


@given(st.floats(0, 1))
def test_apa_p_states_the_value_to_its_precision(p):
    text = apa_p(p)
    if p < 0.001:
        assert text == "p < .001"
    elif p >= 0.9995:
        assert text == "p > .999"
    else:
        assert re.fullmatch(r"p = \.\d{3}", text)
        assert abs(float(text[4:]) - p) <= 0.0005 + 1e-12


# --------------------------------------------------------------------- properties and refusals


@settings(max_examples=40, deadline=None)
@given(
    names=st.lists(
        st.one_of(st.text(min_size=1, max_size=8), st.sampled_from(["C", "I", "Q", "1", "a b"])),
        min_size=4,
        max_size=4,
        unique=True,
    )
)
def test_any_column_names_give_rs_numbers(names):
    # R's table for factors named C and Q, subject I (names patsy's formulas cannot take)
    theirs = R_ANOVA[R_ANOVA["design"] == "formula_names"].reset_index(drop=True)
    data = read_r("anova_formula_names.csv")
    subject, a, b, dv = names
    data = data.rename(columns={"I": subject, "C": a, "Q": b, "y": dv})
    ours = rm_anova(data, dv, [a, b], subject)
    assert list(ours["source"]) == [a, b, f"{a} × {b}"]
    assert_allclose(ours["F"], theirs["F"], rtol=R_TOLERANCE)
    assert_allclose(ours.loc[[0, 2], "p_hf"], theirs.loc[[0, 2], "p_hf"], rtol=R_TOLERANCE)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    levels=st.sampled_from([(3,), (5,), (2, 4), (3, 3), (2, 2, 3)]),
    extra=st.integers(0, 6),
)
def test_epsilons_lie_between_their_bounds(seed, levels, extra):
    # Huynh–Feldt's estimate is at least Greenhouse–Geisser's (algebra: n p ε - 2 ≥ ε p (n - 1
    # - p ε) as p ε ≥ 1) and at most 1 after capping; GG lies in [1/df, 1]
    p_max = max(math.prod(k - 1 for k in subset) for subset in _subsets(levels))
    df, names = random_design(levels, n=p_max + 1 + extra, seed=seed)
    table = rm_anova(df, "v", names, "s")
    assert (table["sphericity"] != "estimated").sum() == (table["df1"] == 1).sum()
    assert (table["eps_gg"] >= 1 / table["df1"] - 1e-12).all()
    assert (table["eps_hf"] >= table["eps_gg"] - 1e-12).all()
    assert (table["eps_hf"] <= 1).all()
    estimated = table[table["df1"] > 1]
    assert ((estimated["mauchly_W"] > 0) & (estimated["mauchly_W"] <= 1 + 1e-12)).all()
    assert ((estimated["mauchly_p"] >= 0) & (estimated["mauchly_p"] <= 1)).all()


def _subsets(levels):
    for order in range(1, len(levels) + 1):
        yield from itertools.combinations(levels, order)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), levels=st.sampled_from([(4,), (6,), (12, 2), (3, 4)]))
def test_too_few_subjects_make_sphericity_not_estimable(seed, levels):
    p_max = max(math.prod(k - 1 for k in subset) for subset in _subsets(levels))
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, p_max + 1))  # at most df subjects for the largest effect
    df, names = random_design(levels, n=n, seed=seed)
    table = rm_anova(df, "v", names, "s").set_index("source")
    for effect in _subsets(range(len(levels))):
        p = math.prod(levels[i] - 1 for i in effect)
        row = table.loc[" × ".join(names[i] for i in effect)]
        if p == 1:
            assert row["sphericity"] == "holds: 1 df"
        elif n <= p:
            assert row["sphericity"] == (
                f"not estimable: {n} subjects for {p} df, needs at least {p + 1}"
            )
            assert math.isnan(row["eps_gg"]) and math.isnan(row["mauchly_W"])
            assert math.isnan(row["p_gg"]) and math.isnan(row["p_hf"])
            assert math.isfinite(row["F"]) and math.isfinite(row["p"])
        else:
            assert row["sphericity"] == "estimated"


def test_a_singular_covariance_with_enough_subjects_is_not_estimable():
    df, _ = random_design((4,), n=8, seed=2)
    wide = df.pivot(index="s", columns="f0", values="v")
    wide["L3"] = 2 * wide["L2"] - wide["L1"]  # collinear scores: rank 2 of 3
    long = wide.reset_index().melt(id_vars="s", var_name="f0", value_name="v")
    row = rm_anova(long, "v", "f0", "s").iloc[0]
    assert row["sphericity"] == "not estimable: the covariance of the 3 contrast scores has rank 2"
    assert math.isnan(row["eps_gg"]) and math.isfinite(row["F"])


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    bad=st.sampled_from([float("nan"), float("inf"), -float("inf")]),
    position=st.integers(0, 23),
)
def test_nan_or_infinite_values_are_refused_by_name(seed, bad, position):
    df, names = random_design((3, 2), n=4, seed=seed)
    df.loc[position, "v"] = bad
    s, f0, f1 = df.loc[position, ["s", "f0", "f1"]]
    with pytest.raises(
        ValueError,
        match=re.escape(
            f"rm_anova: dv 'v' is {bad} for subject {s!r} at {{'f0': {f0!r}, 'f1': {f1!r}}}; "
            "every value must be a finite number (1 of 24 are not)"
        ),
    ):
        rm_anova(df, "v", names, "s")
    long = df[df["f1"] == df.loc[position, "f1"]]
    with pytest.raises(
        ValueError,
        match=re.escape(f"pairwise_tests: dv 'v' is {bad} for subject {s!r} at f0={f0!r}"),
    ):
        pairwise_tests(long, "v", "f0", "s")


def test_rm_anova_refuses_bad_arguments_by_name():
    df, names = random_design((3,), n=5, seed=0)
    with pytest.raises(ValueError, match=r"column dv='v' must be real numbers; got dtype"):
        rm_anova(df.astype({"v": str}), "v", names, "s")
    with pytest.raises(ValueError, match=r"column dv='v' must be real numbers; got dtype complex"):
        rm_anova(df.astype({"v": complex}), "v", names, "s")  # its imaginary part was dropped
    with pytest.raises(
        ValueError,
        match=r"must be different columns; got dv='v', subject='s', within=\['f0', 'f0'\]",
    ):
        rm_anova(df, "v", ["f0", "f0"], "s")
    with pytest.raises(ValueError, match="within must name at least one factor"):
        rm_anova(df, "v", [], "s")


def test_an_effect_without_error_variance_is_refused():
    # F = SS_effect / SS_error is 0/0 (constant data) or effect/rounding (subject + condition,
    # no noise): statsmodels returned F = -2.8 and F = 2e30 for these
    df, names = random_design((3, 2), n=5, seed=3)
    constant = df.assign(v=250.0)
    with pytest.raises(ValueError, match=r"'v' has no error variance for f0: every subject's"):
        rm_anova(constant, "v", names, "s")
    subject = df["s"].str[1:].astype(float)
    additive = df.assign(v=1e4 + 30 * subject + df["f0"].map({"L0": 0.0, "L1": 2.5, "L2": 7.0}))
    with pytest.raises(ValueError, match=r"no error variance for f0: .* F is undefined"):
        rm_anova(additive, "v", names, "s")
    # tiny but real noise is analysed, whatever the unit
    rng = np.random.default_rng(0)
    for unit in (1e-9, 1.0, 1e9):
        noisy = additive.assign(v=unit * (additive["v"] + 1e-4 * rng.normal(size=len(df))))
        assert np.isfinite(rm_anova(noisy, "v", names, "s")["F"]).all()


def test_an_effect_without_error_variance_is_reported_without_dividing_by_it():
    """Participants with identical data printed a bare 'RuntimeWarning: divide by zero' of
    statsmodels' F = MS_effect / MS_error, where the report already says 'no error variance'."""
    import warnings

    from statsmodels.stats.anova import AnovaRM

    df, names = random_design((3, 2), n=5, seed=3)
    rng = np.random.default_rng(1)
    # whole halves: the sums are exact, so the error of f1 is 0, not rounding
    noise = {(s, a): rng.integers(-8, 8) / 2 for s in df["s"].unique() for a in df["f0"].unique()}
    # f1 moves every subject by 2.5 alike: f1 and f0 × f1 have no error variance, f0 has
    data = df.assign(
        v=1e3
        + df["f1"].map({"L0": 0.0, "L1": 2.5})
        + df["f0"].map({"L0": 0.0, "L1": 1.0, "L2": 3.0})
        + [noise[key] for key in zip(df["s"], df["f0"], strict=True)]
    )
    # three participants' identical matches (one session imported three times)
    matches = [283.5, 262.5, 271.5, 250.0, 316.5, 279.5]
    identical = pd.DataFrame(
        {
            "s": np.repeat(["P07", "P08", "P10"], 6),
            "L_disk": [4, 4, 6, 5, 5, 6] * 3,
            "method": ["vos", "gaussian", "gaussian", "vos", "gaussian", "vos"] * 3,
            "v": matches * 3,
        }
    )
    with warnings.catch_warnings(record=True) as caught:  # restored on leaving
        warnings.simplefilter("always")
        table = rm_anova(data, "v", names, "s", untestable="report").set_index("source")
        alike = rm_anova(identical, "v", ["L_disk", "method"], "s", untestable="report")
    assert [str(w.message) for w in caught] == []
    assert (alike["sphericity"] == "not testable").all() and alike["F"].isna().all()
    assert table.loc["f1", "note"].startswith("not testable: 'v' has no error variance for f1")
    assert table.loc["f0 × f1", "sphericity"] == "not testable"
    assert (table.loc["f1", "df1"], table.loc["f1", "df2"]) == (1.0, 4.0)
    with np.errstate(divide="ignore", invalid="ignore"):  # statsmodels' own F of f0
        fitted = AnovaRM(data, "v", "s", within=names).fit().anova_table.loc["f0"]
    assert (table.loc["f0", "df1"], table.loc["f0", "df2"]) == (2.0, 8.0)
    assert table.loc["f0", "F"] == pytest.approx(fitted["F Value"], rel=1e-9)
    assert table.loc["f0", "p"] == pytest.approx(fitted["Pr > F"], rel=1e-9)


def test_t_tests_refuse_nan_instead_of_returning_it():
    with pytest.raises(
        ValueError,
        match=r"ttest_paired: a is nan at position 1; every value must be a finite number \(1 of 3",
    ):
        ttest_paired([1.0, np.nan, 3.0], [1.5, 2.0, 2.5])
    with pytest.raises(ValueError, match=r"ttest_welch: b is inf at position 0"):
        ttest_welch([1.0, 2.0], [np.inf, 2.0])
    with pytest.raises(ValueError, match=r"same size, at least 2; got 3 and 2"):
        ttest_paired([1.0, 2.0, 3.0], [1.0, 2.0])


def test_pairwise_tests_name_a_missing_or_repeated_cell():
    df, _ = random_design((4,), n=6, seed=1)
    with pytest.raises(
        ValueError,
        match=r"exactly one 'v' per subject and level of 'f0'; subject 'S1' has 0 at f0='L2'",
    ):
        pairwise_tests(df.drop(index=6), "v", "f0", "s")
    with pytest.raises(ValueError, match=r"subject 'S0' has 2 at f0='L0'"):
        pairwise_tests(pd.concat([df, df.iloc[[0]]]), "v", "f0", "s")
    with pytest.raises(ValueError, match=r"got nan at position 1"):
        holm([0.2, float("nan")])


def brute_force_signed_rank_p(differences):
    """Two-sided exact p by enumerating all 2^n sign patterns (no ties, no zeros)."""
    n = len(differences)
    ranks = sps.rankdata(np.abs(differences))
    observed = ranks[np.asarray(differences) > 0].sum()
    centre = n * (n + 1) / 4
    totals = [
        sum(r for r, sign in zip(ranks, signs, strict=True) if sign)
        for signs in itertools.product([0, 1], repeat=n)
    ]
    extreme = sum(abs(t - centre) >= abs(observed - centre) - 1e-9 for t in totals)
    return min(1.0, extreme / 2**n)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.floats(-50, 50).filter(lambda v: abs(v) > 1e-3), min_size=1, max_size=11, unique_by=abs
    )
)
def test_exact_wilcoxon_is_the_enumerated_null_distribution(differences):
    ours = wilcoxon_signed_rank(np.asarray(differences) + 4.0, mu=4.0)
    shifted = list(np.asarray(differences) + 4.0 - 4.0)
    if len(set(np.abs(shifted))) < len(shifted) or 0.0 in shifted:
        return  # the shift made a tie or a zero (floating point): the normal variant
    assert ours["method"] == "exact"
    assert_allclose(ours["p"], brute_force_signed_rank_p(shifted), rtol=1e-12)
    mirrored = wilcoxon_signed_rank(-np.asarray(shifted))
    n = len(shifted)
    assert mirrored["V"] == n * (n + 1) / 2 - ours["V"]
    assert_allclose(mirrored["p"], ours["p"], rtol=1e-12)


def test_wilcoxon_refusals():
    with pytest.raises(ValueError, match=r"x is nan at position 2; every value must be a finite"):
        wilcoxon_signed_rank([5.0, 6.0, np.nan], mu=4)
    with pytest.raises(ValueError, match=r"all 3 values of x equal mu=4"):
        wilcoxon_signed_rank([4, 4, 4], mu=4)
    with pytest.raises(ValueError, match=r"mu must be a finite number; got nan"):
        wilcoxon_signed_rank([4, 5], mu=float("nan"))
    with pytest.raises(ValueError, match=r"x is empty"):
        wilcoxon_signed_rank([], mu=4)


def test_an_effect_of_exactly_zero_is_f_zero_not_a_crash():
    """Settings on a 50 cd/m² grid can give two methods equal means: the effect's sum of squares
    is 0 and statsmodels' F comes out as -1e-14 from rounding, which the η²p interval refused."""
    from glarelab.analysis.effects import with_eta2_ci

    rng = np.random.default_rng(1)
    values = (
        250
        + np.linspace(0, 60, 6)[None, None, :]
        + rng.normal(0, 15, (10, 2, 6))
        + rng.normal(0, 20, (10, 1, 1))
    )
    values = np.round(values / 50) * 50  # the two methods' means are equal on this grid
    rows = [
        {"participant": f"p{p:02d}", "method": m, "level": str(k), "match_cd_m2": values[p, i, k]}
        for p in range(10)
        for i, m in enumerate(("gaussian", "vos"))
        for k in range(6)
    ]
    table = rm_anova(pd.DataFrame(rows), "match_cd_m2", ["level", "method"], "participant")
    method = table.set_index("source").loc["method"]
    assert method["F"] >= 0.0
    assert_allclose(method["F"], 0.0, atol=1e-9)
    assert with_eta2_ci(table).set_index("source").loc["method", "eta2_partial"] < 1e-9


def test_the_paired_test_and_the_anova_agree_on_a_difference_at_rounding():
    """Method II = Method I + 1 ulp: the ANOVA finds no error variance, so the paired test of
    the same matches must not report d_z = -0.77 and a significant difference."""
    rng = np.random.default_rng(4)
    first = rng.uniform(200, 400, (10, 3))
    second = np.nextafter(first, np.inf)
    result = ttest_paired(first[:, 0], second[:, 0])
    assert result["note"].startswith("not testable"), result
    rows = [
        {"participant": f"p{p}", "method": m, "level": str(k), "match_cd_m2": v[p, k]}
        for p in range(10)
        for m, v in (("gaussian", first), ("vos", second))
        for k in range(3)
    ]
    table = rm_anova(
        pd.DataFrame(rows), "match_cd_m2", ["level", "method"], "participant", untestable="report"
    )
    assert table.set_index("source").loc["method", "note"].startswith("not testable")


@settings(max_examples=300, deadline=None)
@given(
    rms=st.floats(min_value=1e-100, max_value=1e100),
    steps=st.integers(min_value=-3, max_value=3),
)
def test_the_paired_test_decides_no_variance_as_it_did_by_its_sd(rms, steps):
    """ttest_paired asks the ANOVA's rule of the differences' variance (sd²) where it compared
    their sd with ``ROUNDING`` of the values' RMS: squaring is strictly increasing on normal
    numbers, so the two agree at every sd, the threshold's neighbours included."""
    threshold = ROUNDING * rms
    sd = threshold
    for _ in range(abs(steps)):
        sd = math.nextafter(sd, math.inf if steps > 0 else 0.0)
    assert _no_variance(sd**2, rms) == (sd <= threshold)
    assert _no_variance(float("nan"), rms)  # the ANOVA's NaN variance: no test


# R 4.2's t.test of the same data at an ordinary scale (t, df, p, interval): t, df and p do
# not depend on the unit, and the interval scales with it. R's own t.test gives t = 0, p = 1
# at 1e300 (its variance overflows to Inf).
R_SCALED_TTESTS = [
    (
        lambda k: ttest_one_sample([1 * k, 2 * k, 3 * k]),
        (
            3.464101615137754830,
            2.0,
            0.074179900227448525,
            -0.484137711750329769,
            4.484137711750329380,
        ),
    ),
    (
        lambda k: ttest_one_sample([-k, 0.0, k], mu=0.5 * k),
        (
            -0.86602540378443871,
            2.0,
            0.47776703213290650,
            -2.48413771175032982,
            2.48413771175032982,
        ),
    ),
    (
        lambda k: ttest_paired([3 * k, 5 * k, 4 * k], [k, k, k]),
        (
            5.196152422706632024,
            2.0,
            0.035098718645984649,
            0.515862288249670065,
            5.484137711750329380,
        ),
    ),
    (
        lambda k: ttest_welch([1 * k, 2 * k, 3 * k], [5 * k, 6 * k, 8 * k]),
        (
            -4.110960958218892181,
            3.448275862068966635,
            0.019855117523634853,
            -7.454217285228927459,
            -1.212449381437738172,
        ),
    ),
]


@pytest.mark.parametrize("scale", [1.0, 1e300, 1e-300, 1e-160])
@pytest.mark.parametrize("case", range(len(R_SCALED_TTESTS)))
def test_t_tests_do_not_depend_on_the_unit_of_the_values(case, scale):
    """At 1e300 the squares overflowed (t = 0, p = 1, or a false "essentially constant"
    note), at 1e-300 they underflowed (a false note): the tests now work on the values
    divided by a power of two near their magnitude."""
    call, expected = R_SCALED_TTESTS[case]
    result = call(scale)
    assert not result["note"], result
    ours = [
        result["t"],
        result["df"],
        result["p"],
        result["ci_low"] / scale,
        result["ci_high"] / scale,
    ]
    assert_allclose(ours, expected, rtol=R_TOLERANCE)


@pytest.mark.parametrize(
    ("call", "what"),
    [
        (lambda: ttest_one_sample([1e308, 1.5e308, 1.7e308]), "upper end"),
        (lambda: ttest_one_sample([-1e308, 0.0, 1e308], mu=1e308), "lower end"),
        (lambda: ttest_paired([1.7e308, -1.7e308, 1.7e308], [-1.7e308, 1.7e308, 0.0]), "interval"),
        (lambda: ttest_welch([1.7e308, 1.6e308], [-1.7e308, -1.6e308]), "difference"),
    ],
)
def test_t_tests_refuse_results_beyond_float64_rather_than_print_inf(call, what):
    with pytest.raises(ValueError, match=f"too large to compute with: the .*{what}.*1.8e308"):
        call()
