"""Data a lab gets and the simulated observers rarely make, against R
(``tests/analysis/R/real_data.R``: afex, car, effectsize, multcompView, stats): matches at the
display's maximum, both methods set alike, a constant difference, a negative boost, a design
whose corrected and uncorrected tests disagree, Spencer's shape with too few participants for
sphericity, ratings whose median is the midpoint, and staircases whose intensities drifted.
Every number is R's to rounding, and every sentence of the results text is checked against
R's numbers: its verdict against R's decision, its printed values against R's values, and
each interval beside a test against that test's decision."""

import functools
import math
import re

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from glarelab.analysis import matching, rating, staircase
from glarelab.analysis.apa import anova_effect
from glarelab.analysis.dataset import Dataset
from glarelab.analysis.effects import with_eta2_ci
from glarelab.analysis.stats import corrected_p, correction, rm_anova
from glarelab.protocols import load_protocol

from .test_stats import read_r

R_TOLERANCE = 1e-9  # the same methods as R's: agreement to rounding
# effectsize's own limits (Nelder–Mead to 1e-9 on the probabilities) stop up to 4e-4 from the
# roots at corrected (fractional) df, where the uniroot reference agrees with ours to 1e-9
OPTIM_TOLERANCE = 1e-3
PT_ACCURATE_NCP = 37.62  # R's pt: beyond this noncentrality an approximation (AS 243)
ALPHA = 0.05
YOSHIDA = load_protocol("yoshida2008")
LABELS = {m["name"]: m["labels"] for m in YOSHIDA["glare"]["methods"]}
ANALYSES = {
    "6 x 2 (all levels)": "6 × 2 (all levels)",
    "3 x 2 ({A, B, C})": "3 × 2 ({A, B, C})",
    "3 x 2 ({D, E, F})": "3 × 2 ({D, E, F})",
}


def matching_dataset(design: str) -> Dataset:
    """The matches of an R design as the trials of a yoshida2008 study (one setting: darker,
    brighter and match alike)."""
    data = read_r(f"real_matching_{design}.csv")
    trials = pd.DataFrame(
        {
            "participant": data["participant"],
            "block": "main",
            "method": data["method"],
            "level_index": data["level_index"],
            "level": [
                LABELS[m][k - 1] for m, k in zip(data["method"], data["level_index"], strict=True)
            ],
            "l_disk_cd_m2": data["l_disk_cd_m2"].astype(float),
            "darker_cd_m2": data["match_cd_m2"],
            "brighter_cd_m2": data["match_cd_m2"],
            "match_cd_m2": data["match_cd_m2"],
            "q1_glow": True,
            "q2_ring": False,
            "q3_same_size": True,
        }
    )
    return Dataset(study="yoshida2008", trials=trials, files=[])


@functools.cache
def analysis(design: str) -> dict:
    """The report's analysis of an R design (figures and all: seconds, so made once)."""
    return matching.analyse(matching_dataset(design), YOSHIDA)


@pytest.fixture(scope="module", params=["saturated", "constant_and_negative"])
def analysed(request):
    return request.param, analysis(request.param)


def nct_cdf(t: float, dof: int, ncp: float) -> float:
    """The noncentral t CDF by quadrature over the chi-square: an independent reference where
    R's pt approximates (noncentrality beyond 37.62)."""
    from scipy import integrate
    from scipy import stats as sps

    def integrand(v):
        return sps.norm.cdf(t * math.sqrt(v / dof) - ncp) * sps.chi2.pdf(v, dof)

    value, _ = integrate.quad(integrand, 0, np.inf, limit=500, epsabs=1e-14, epsrel=1e-12)
    return value


def pct(level: float) -> str:
    return f"{100 * level:.1f}".rstrip("0").rstrip(".")


def test_the_anovas_match_afex_and_decide_on_the_correction_r_would(analysed):
    design, result = analysed
    ours = result["tables"]["anova"]
    theirs = read_r("real_matching_anova.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    assert list(ours["analysis"]) == [ANALYSES[a] for a in theirs["analysis"]]
    assert [s.replace(" × ", ":") for s in ours["source"]] == list(theirs["source"])
    for column in ("F", "MSE", "p", "p_lb", "eta2_partial", "eta2_generalized"):
        assert_allclose(ours[column], theirs[column], rtol=R_TOLERANCE, err_msg=column)
    # R's car calls the error matrix singular exactly where sphericity is not estimable here
    assert list(ours["sphericity"].str.startswith("not estimable")) == list(theirs["singular"])
    assert list(ours.apply(correction, axis=1)) == list(theirs["correction"])
    assert_allclose(ours.apply(corrected_p, axis=1), theirs["p_decided"], rtol=R_TOLERANCE)
    estimated = theirs["eps_gg"].notna()
    assert_allclose(ours.loc[estimated, "eps_gg"], theirs.loc[estimated, "eps_gg"], rtol=1e-9)
    shown = with_eta2_ci(ours)
    for column in ("eta2p_ci_low", "eta2p_ci_high"):
        assert_allclose(shown[column], theirs[column], atol=R_TOLERANCE)  # noncentral F
        assert_allclose(
            shown[column], theirs[column.replace("eta2p", "effectsize")], atol=OPTIM_TOLERANCE
        )


def test_every_anova_sentence_follows_rs_decision_and_its_interval_agrees(analysed):
    design, result = analysed
    theirs = read_r("real_matching_anova.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    text = result["results"][0]
    effects = re.findall(
        r"(the main effect of level|the main effect of glare method|the level × method "
        r"interaction) (was significant|was not significant|could not be tested), "
        r"F\(([\d.]+), ([\d.]+)\) = ([\d.]+), p ([<=>]) \.(\d+), η²p = \.\d\d, 90 % CI "
        r"\[([.\d]+), ([.\d]+)\]",
        text,
    )
    assert len(effects) == len(theirs)  # every effect, in the table's order
    for found, (_, row) in zip(effects, theirs.iterrows(), strict=True):
        _, verdict, df1, df2, f_value, sign, p_digits, low, _ = found
        significant = row["p_decided"] < ALPHA
        assert verdict == ("was significant" if significant else "was not significant")
        eps = {"none": 1, "LB": 1 / row["df1"]}.get(row["correction"])
        if eps is None:
            eps = row["eps_gg"] if row["correction"] == "GG" else row["eps_hf"]
        assert float(df1) == pytest.approx(row["df1"] * eps, abs=0.005)
        assert float(df2) == pytest.approx(row["df2"] * eps, abs=0.005)
        assert float(f_value) == pytest.approx(row["F"], abs=0.005)
        if sign == "=":
            assert float("0." + p_digits) == pytest.approx(row["p_decided"], abs=0.0005)
        else:
            assert row["p_decided"] < 0.001
        decimals = len(low.split(".")[1])
        assert float(low) == pytest.approx(row["eta2p_ci_low"], abs=0.5 * 10**-decimals)
        # the 90 % interval excludes 0 exactly when the test it is printed with is significant
        assert (row["eta2p_ci_low"] > 0) == significant
        if row["correction"] == "LB":
            assert "lower-bound corrected, ε = 1/" in text


def test_the_methods_at_levels_match_t_test_and_leave_the_untestable_out(analysed):
    design, result = analysed
    theirs = read_r("real_matching_methods.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    ours = result["tables"]["methods_at_levels"]
    paired = ours[ours["test"] == "paired"].reset_index(drop=True)
    welch = ours[ours["test"] == "Welch"].reset_index(drop=True)
    for column, theirs_column in (("t", "paired_t"), ("p_two_sided", "paired_p"),
                                  ("p_holm", "p_holm"), ("confidence", "level"),
                                  ("md_ci_low", "md_ci_low"), ("md_ci_high", "md_ci_high"),
                                  ("mean_difference", "mean_difference")):  # fmt: skip
        assert_allclose(paired[column], theirs[theirs_column], rtol=R_TOLERANCE, atol=1e-12)
    for column, theirs_column in (("t", "welch_t"), ("df", "welch_df"),
                                  ("p_two_sided", "welch_p"), ("md_ci_low", "welch_low"),
                                  ("md_ci_high", "welch_high")):  # fmt: skip
        # Welch's rows carry Welch's own interval, not the paired test's
        assert_allclose(welch[column], theirs[theirs_column], rtol=R_TOLERANCE, atol=1e-12)
    untested = theirs["paired_p"].isna()
    assert (paired.loc[untested, "note"].str.startswith("not testable")).all()
    assert (paired.loc[~untested, "note"] == "").all()
    constant = theirs["welch_why"].str.contains("essentially constant", na=False)
    assert welch.loc[constant, "note"].str.contains("essentially constant").all()
    sizes = result["tables"]["effect_sizes"]
    d_z = sizes[sizes["effect_size"] == "d_z"].reset_index(drop=True)
    assert_allclose(d_z["ci_low"], theirs["dz_ci_low"], rtol=1e-9, atol=1e-12)
    assert_allclose(d_z["ci_high"], theirs["dz_ci_high"], rtol=1e-9, atol=1e-12)


def test_every_comparison_sentence_follows_rs_numbers(analysed):
    design, result = analysed
    theirs = read_r("real_matching_methods.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    text = result["results"][1]
    for _, row in theirs.iterrows():
        level = (
            f"{LABELS['gaussian'][row['level_index'] - 1]}/{LABELS['vos'][row['level_index'] - 1]}"
        )
        sentence = re.search(rf"at {re.escape(level)} the matches .*?(?:;|\.$| Yoshida)", text)
        assert sentence, level
        sentence = sentence.group(0)
        if math.isnan(row["paired_p"]):
            assert "could not be compared: the differences are all 0" in sentence
            continue
        differs = row["p_holm"] < ALPHA
        assert (" differed, " in sentence) == differs and ("did not differ" in sentence) != differs
        assert f"t(9) = {row['paired_t']:.2f}" in sentence
        interval = f"{pct(row['level'])} % CI [{row['md_ci_low']:.1f}, {row['md_ci_high']:.1f}]"
        assert interval in sentence
        assert (row["md_ci_low"] > 0 or row["md_ci_high"] < 0) == differs
        assert (row["dz_ci_low"] > 0 or row["dz_ci_high"] < 0) == differs


def test_the_level_contrasts_match_r_with_intervals_and_letters(analysed):
    design, result = analysed
    theirs = read_r("real_matching_contrasts.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    ours = result["tables"]["pairwise_contrasts"]
    assert len(ours) == len(theirs)
    for column, theirs_column in (("t", "t"), ("p", "p"), ("p_holm", "p_holm"),
                                  ("confidence", "level"), ("md_ci_low", "md_ci_low"),
                                  ("md_ci_high", "md_ci_high")):  # fmt: skip
        assert_allclose(ours[column], theirs[theirs_column], rtol=1e-9, atol=1e-12)
    # d_z's interval: R's where its pt is exact; beyond, against the noncentral t by quadrature
    n = 10
    accurate = (theirs["t"].abs() + 3) * 1.5 < PT_ACCURATE_NCP
    for column in ("dz_ci_low", "dz_ci_high"):
        assert_allclose(ours.loc[accurate, column], theirs.loc[accurate, column], rtol=1e-9)
    for row in ours[~accurate & ours["t"].notna()].itertuples():
        for limit, probability in ((row.dz_ci_low, (1 + row.confidence) / 2),
                                   (row.dz_ci_high, (1 - row.confidence) / 2)):  # fmt: skip
            assert_allclose(nct_cdf(row.t, n - 1, limit * math.sqrt(n)), probability, atol=1e-9)
    assert (ours["note"].str.startswith("not testable") == theirs["p"].isna()).all()
    significant = ours["p_holm"] < ALPHA
    excludes = (ours["md_ci_low"] > 0) | (ours["md_ci_high"] < 0)
    assert (excludes == significant).all()
    groups = result["tables"]["similarity_groups"].set_index(["method", "level"])["group"]
    for row in theirs.itertuples():
        for index, letters in ((row.a, row.letters_a), (row.b, row.letters_b)):
            label = LABELS[row.method][index - 1]
            # the same groups as multcompView (letters name them in order of the means)
            assert len(groups[(row.method, label)]) == len(letters)


def test_the_boost_sentence_follows_its_one_sample_test(analysed):
    design, result = analysed
    theirs = read_r("real_matching_boost.csv")
    theirs = theirs[theirs["design"] == design].reset_index(drop=True)
    ours = result["tables"]["boost_test"]
    for column, theirs_column in (("t", "t"), ("p", "p"), ("p_holm", "p_holm"),
                                  ("confidence", "level"), ("ci_low", "ci_low"),
                                  ("ci_high", "ci_high"),
                                  ("boost_percent_mean", "mean")):  # fmt: skip
        assert_allclose(ours[column], theirs[theirs_column], rtol=R_TOLERANCE, atol=1e-12)
    text = result["results"][2]
    assert text.startswith("At the highest level, compared with the luminance the display")
    for row in theirs.itertuples():
        title = {"gaussian": "Method I (Gaussian)", "vos": "Method II (Vos PSF)"}[row.method]
        sentence = text.split(f"with {title}")[1].split("; with")[0]
        if math.isnan(row.p):
            assert "the boost could not be tested: the values are essentially constant" in sentence
        elif row.p_holm < ALPHA and row.mean < 0:
            assert f"fell short of it by {-row.mean:.1f} %" in sentence
        elif row.p_holm < ALPHA:
            assert f"exceeded it by {row.mean:.1f} %" in sentence
        else:
            assert "did not differ from it" in sentence
        if not math.isnan(row.p):
            assert f"{pct(row.level)} % CI [{row.ci_low:.1f}, {row.ci_high:.1f}]" in sentence


def test_a_negative_boost_falls_short_and_is_never_said_to_exceed():
    result = analysis("constant_and_negative")
    text = result["results"][2]
    assert (
        "with Method I (Gaussian) at F (7,000 cd/m²) the matches fell short of it by 16.2 %"
        in (text)
    )
    assert "exceeded it by -" not in text


def test_the_methods_set_alike_and_the_constant_difference_are_named_not_tested():
    result = analysis("constant_and_negative")
    text = result["results"][1]
    assert "at D/d the matches" in text
    assert "could not be compared: the differences are all 0 (the participants' matches:" in text
    contrasts = result["tables"]["pairwise_contrasts"].set_index(["method", "a", "b"])
    constant = contrasts.loc[("vos", "e", "f")]
    assert constant["note"].startswith("not testable: the differences are essentially constant")
    assert math.isnan(constant["p"]) and math.isnan(constant["p_holm"])
    assert "p = 0" not in " ".join(result["results"])


def test_the_saturated_levels_do_not_abort_and_name_the_participants():
    result = analysis("saturated")
    text = " ".join(result["results"])
    assert "at E/e the matches under Method I (Gaussian) (M = 423.0 cd/m²)" in text
    assert "could not be compared: the differences are all 0 (the participants' matches: all " in (
        text
    )
    assert "10: 423 and 423 cd/m²)" in text


def test_a_corrected_test_that_disagrees_with_the_uncorrected_decides_and_its_interval_agrees():
    theirs = read_r("real_anova.csv").set_index("design").loc["disagree"]
    assert theirs["p"] < ALPHA <= theirs["p_decided"]  # the design R chose for this
    table = with_eta2_ci(rm_anova(read_r("real_disagree_data.csv"), "y", "cue", "subject"))
    row = table.iloc[0]
    assert correction(row) == theirs["correction"] == "GG"
    assert_allclose(corrected_p(row), theirs["p_decided"], rtol=R_TOLERANCE)
    assert_allclose(row["MSE"], theirs["MSE"], rtol=R_TOLERANCE)
    assert_allclose(
        [row["eta2p_ci_low"], row["eta2p_ci_high"]],
        [theirs["eta2p_ci_low"], theirs["eta2p_ci_high"]],
        rtol=R_TOLERANCE,
        atol=1e-12,
    )
    assert row["eta2p_ci_low"] == 0  # the uncorrected df's interval excluded 0
    text = anova_effect(row)
    assert text.startswith(
        f"F({4 * row['eps_gg']:.2f}, {28 * row['eps_gg']:.2f}) = 2.77, p = .106"
    )
    assert "90 % CI [.00," in text


def test_spencers_shape_with_ten_participants_decides_on_the_lower_bound():
    theirs = read_r("real_anova.csv")
    theirs = theirs[theirs["design"] == "spencer_10"].reset_index(drop=True)
    data = read_r("real_spencer_10.csv")
    ours = with_eta2_ci(rm_anova(data, "y", ["glare_level", "context"], "subject"))
    assert list(ours.apply(correction, axis=1)) == list(theirs["correction"])
    assert_allclose(ours["p_lb"], theirs["p_lb"], rtol=R_TOLERANCE)
    assert_allclose(ours.apply(corrected_p, axis=1), theirs["p_decided"], rtol=R_TOLERANCE)
    for column in ("eta2p_ci_low", "eta2p_ci_high"):
        assert_allclose(ours[column], theirs[column], rtol=R_TOLERANCE, atol=1e-12)
    level = ours.iloc[0]
    assert level["p"] < ALPHA <= corrected_p(level)  # the lower bound reverses it
    text = anova_effect(level)
    assert text.startswith("F(1, 9) = 3.57, p = .091")
    assert "(lower-bound corrected, ε = 1/11: sphericity not estimable: 10 subjects" in text
    assert "uncorrected F(11, 99) = 3.57, p < .001)" in text


RATINGS = read_r("real_ratings.csv")


@pytest.fixture(scope="module")
def ratings():
    protocol = load_protocol("luidolt2020")
    data = {**protocol.data, "questionnaire": {**protocol.data["questionnaire"]}}
    data["questionnaire"]["categories"] = list(RATINGS["category"])
    import dataclasses

    protocol = dataclasses.replace(protocol, data=data)
    rows = [
        {"participant": f"p{i + 1:02d}", "category": c, "rating": int(v), "comment": None,
         "block": "questionnaire"}
        for c, ratings_ in zip(RATINGS["category"], RATINGS["ratings"], strict=True)
        for i, v in enumerate(ratings_.split(";"))
    ]  # fmt: skip
    dataset = Dataset(study="luidolt2020", trials=pd.DataFrame(rows), files=[])
    return rating.analyse(dataset, protocol)


def test_ratings_match_wilcox_test_with_its_estimate_and_interval(ratings):
    ours = ratings["tables"]["summary"]
    theirs = RATINGS
    tested = theirs["p"].notna()  # R: V = 0 and p NaN where every rating is the midpoint
    for column, theirs_column in (("wilcoxon_V", "V"), ("p", "p"), ("p_holm", "p_holm"),
                                  ("confidence", "level"), ("r_rb", "r_rb"),
                                  ("rb_ci_low", "rb_ci_low"),
                                  ("rb_ci_high", "rb_ci_high")):  # fmt: skip
        assert_allclose(
            ours.loc[tested, column], theirs.loc[tested, theirs_column], rtol=R_TOLERANCE
        )
    assert ours.loc[~tested, ["wilcoxon_V", "p", "p_holm"]].isna().all().all()
    # R's estimate is the location of the ratings: the shift from the midpoint is it minus 4
    assert_allclose(ours.loc[tested, "hl_shift"] + 4, theirs.loc[tested, "estimate"], rtol=1e-12)
    interval = tested & theirs["ci_low"].notna()
    for column in ("hl_ci_low", "hl_ci_high"):
        assert_allclose(
            ours.loc[interval, column] + 4,
            theirs.loc[interval, column.removeprefix("hl_")],
            rtol=1e-12,
        )
    assert_allclose(ours.loc[interval, "hl_confidence"], theirs.loc[interval, "conf_level"])


def test_a_median_at_the_midpoint_is_put_on_the_side_of_its_signed_ranks(ratings):
    text = ratings["results"][0]
    above = re.search(r"above_at_median \(Mdn = 4,.*?, V = \d+", text).group(0)
    below = re.search(r"below_at_median \(Mdn = 4,.*?, V = \d+", text).group(0)
    assert "differed from the midpoint (above it), V = 78" in above  # 12 fives, 13 fours
    assert "differed from the midpoint (below it), V = 0" in below  # 12 threes, 13 fours
    assert "midpoint (Mdn = 4, IQR = 0; M = 4.00, SD = 0.00) was not tested" in text


def test_drifted_intensities_are_one_intensity_on_the_grid():
    written = read_r("real_staircases.csv")
    glm = read_r("real_staircases_glm.csv").set_index(["staircase", "scale"])
    spencer = load_protocol("spencer1995")
    for name, part in written.groupby("staircase", sort=False):
        data = part[["disc_fraction", "response"]].reset_index(drop=True)
        on_grid = staircase.on_grid(data, spencer)
        assert data["disc_fraction"].nunique() == glm.loc[(name, "written"), "distinct"]
        assert on_grid["disc_fraction"].nunique() == glm.loc[(name, "grid"), "distinct"]
        fit = staircase.psychometric_fit(on_grid)
        theirs = glm.loc[(name, "grid")]
        if theirs["fitted_0_or_1"]:  # glm's warning of separation: the slope has no bound
            assert theirs["highest_glare"] == theirs["lowest_disc"] == fit["match"]
            assert fit["status"].startswith("estimated: the answers change at one disc")
            # as written, the drift hid the separation: a finite but arbitrary slope
            assert staircase.psychometric_fit(data)["status"] != fit["status"]
        else:
            assert fit["status"] == "estimated"
            assert_allclose(fit["match"], theirs["centre"], rtol=1e-9)
            assert_allclose(fit["slope"], theirs["b1"], rtol=1e-9)


def test_a_darker_target_set_above_the_brighter_is_flagged():
    dataset = matching_dataset("saturated")
    trials = dataset.trials.assign(_file="p01.csv", _line=range(2, len(dataset.trials) + 2))
    trials.loc[3, "darker_cd_m2"] = trials.loc[3, "brighter_cd_m2"] + 5.0
    flags = matching.flags(trials, YOSHIDA)
    assert len(flags) == 1
    assert flags[0].startswith("p01.csv, line 5: participant p01, gaussian D: the darker target")


@pytest.mark.parametrize("all_at_maximum", [False, True], ids=["nine", "all"])
def test_matches_at_the_display_maximum_are_said_to_bound_the_boost(all_at_maximum):
    """Every participant at the display's maximum (433 cd/m²) at the highest level: the boost
    is what the display allows, and the sentence says so instead of reporting it as a finding
    (all ten there: 'could not be tested', and the bound was not said)."""
    protocol = load_protocol("yoshida2008")
    labels = {m["name"]: m["labels"] for m in protocol["glare"]["methods"]}
    disk = {m["name"]: m["levels_cd_m2"] for m in protocol["glare"]["methods"]}
    rng = np.random.default_rng(1)
    matches = 250 + np.linspace(0, 60, 6) + rng.normal(0, 15, (10, 2, 6))
    matches[:, :, 5] = protocol["display"]["max_cd_m2"]
    if all_at_maximum:  # the boosts then all alike: not testable, and still bounded
        text, counts = _at_maximum(protocol, labels, disk, matches)
        assert text.count("the boost could not be tested") == 2
        assert text.count("10 of 10 participants matched at the display's maximum") == 2
        assert (counts == 10).all()
        return
    matches[0, :, 5] -= 1.0  # one participant just below: the rest are counted
    text, counts = _at_maximum(protocol, labels, disk, matches)
    assert text.count("9 of 10 participants matched at the display's maximum, 433 cd/m²") == 2
    assert (counts == 9).all()


def _at_maximum(protocol, labels, disk, matches):
    rows = [
        {
            "participant": f"p{p + 1:02d}",
            "block": "main",
            "method": m,
            "level_index": k + 1,
            "level": labels[m][k],
            "l_disk_cd_m2": float(disk[m][k]),
            "darker_cd_m2": matches[p, i, k],
            "brighter_cd_m2": matches[p, i, k],
            "match_cd_m2": matches[p, i, k],
            "q1_glow": True,
            "q2_ring": False,
            "q3_same_size": True,
        }
        for p in range(10)
        for i, m in enumerate(("gaussian", "vos"))
        for k in range(6)
    ]
    result = matching.analyse(Dataset("yoshida2008", pd.DataFrame(rows), []), protocol)
    return result["results"][2], result["tables"]["boost_test"]["n_at_display_max"]


def luidolt_ratings(first_category: list[int]) -> Dataset:
    """Ratings of Luidolt's categories: the first as given, every other at the midpoint."""
    categories = load_protocol("luidolt2020")["questionnaire"]["categories"]
    n = len(first_category)
    rows = [
        {
            "participant": f"p{i + 1:02d}",
            "category": c,
            "rating": first_category[i] if c == categories[0] else 4,
            "comment": None,
            "block": "questionnaire",
        }
        for c in categories
        for i in range(n)
    ]
    return Dataset("luidolt2020", pd.DataFrame(rows), [])


def test_one_participants_ratings_are_described_not_tested():
    """One participant: no SD, no signed-rank test, no interval (R: level 0)."""
    text = rating.analyse(luidolt_ratings([6]), load_protocol("luidolt2020"))["results"][0]
    assert text.startswith("One participant's ratings (no test")
    assert "nan" not in text and "CI" not in text


def test_ratings_all_at_the_midpoint_describe_no_holm_family():
    text = rating.analyse(luidolt_ratings([4] * 10), load_protocol("luidolt2020"))["results"][0]
    assert "were not compared with the scale's midpoint, 4: every rating" in text
    assert "Holm" not in text and "0 categories" not in text
