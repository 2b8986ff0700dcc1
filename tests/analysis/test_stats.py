import itertools

import numpy as np
import pandas as pd
import pingouin as pg  # test-only dependency: the independent implementation
import pytest
from numpy.testing import assert_allclose

from analysis.stats import (
    apa_F,
    apa_t,
    holm,
    pairwise_tests,
    rm_anova,
    similarity_groups,
    ttest_paired,
    ttest_welch,
)

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
