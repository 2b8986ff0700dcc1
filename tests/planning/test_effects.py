import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy import stats as sps

from glarelab import protocols
from glarelab.analysis.stats import rm_anova
from glarelab.planning.effects import CORRECTIONS, PARADIGMS, anova_effects, chosen_p


def test_every_paradigm_has_a_reader_of_its_effects():
    assert set(PARADIGMS) == set(protocols.PARADIGMS)


def _table(n, k, seed):
    rng = np.random.default_rng(seed)
    y = rng.normal(size=(n, k)) + np.linspace(0, 1, k) + rng.normal(size=(n, 1))
    data = pd.DataFrame(
        {"s": np.repeat(np.arange(n), k), "c": np.tile(np.arange(k), n), "y": y.ravel()}
    )
    return rm_anova(data, "y", "c", "s")


@settings(max_examples=30, deadline=None)
@given(n=st.integers(3, 12), k=st.integers(2, 8), seed=st.integers(0, 2**32 - 1))
def test_corrections_order_their_p_values(n, k, seed):
    """Where the uncorrected test is near significance, uncorrected ≤ Huynh-Feldt ≤
    Greenhouse-Geisser ≤ lower bound (fewer degrees of freedom, a heavier tail; for F near 1
    the order can turn); the lower bound where sphericity cannot be estimated (fewer subjects
    than df + 1)."""
    row = anova_effects(_table(n, k, seed))[0]
    p = {c: chosen_p(row, c) for c in CORRECTIONS}
    lower = sps.f.sf(row["statistic"], 1, row["df2"] / row["df1"])
    if row["eps_gg"] is None:
        assert n - 1 < k - 1
        for c in ("gg", "hf", "girden"):
            assert p[c] == (pytest.approx(lower, rel=1e-12), "lower bound")
    elif row["p"] < 0.1:
        assert p["none"][0] <= p["hf"][0] * (1 + 1e-12)
        assert p["hf"][0] <= p["gg"][0] * (1 + 1e-12)
        assert p["gg"][0] <= lower * (1 + 1e-12)
    if row["eps_gg"] is not None:
        assert p["girden"][1] == ("GG" if row["eps_gg"] < 0.75 else "HF")
    assert p["none"] == (row["p"], "uncorrected")


def test_a_correction_that_does_not_exist_is_refused():
    row = anova_effects(_table(6, 3, 1))[0]
    with pytest.raises(
        ValueError, match="correction must be one of gg, hf, girden, none; got 'GG'"
    ):
        chosen_p(row, "GG")


def test_other_tests_are_judged_by_their_own_p():
    assert chosen_p({"test": "t", "p": 0.03}, "gg") == (0.03, "as tested")


def test_effect_sizes_of_t_tests_and_wilcoxon_tests():
    matching = PARADIGMS["matching"]
    table = pd.DataFrame(
        [
            {
                "level": "D/d",
                "methods": "a > b",
                "test": "paired",
                "t": 3.0,
                "df": 8.0,
                "p_two_sided": 0.017,
                "p_one_sided": 0.008,
            },
            {
                "level": "D/d",
                "methods": "a > b",
                "test": "Welch",
                "t": 2.0,
                "df": 15.2,
                "p_two_sided": 0.06,
                "p_one_sided": 0.03,
            },
        ]
    )
    rows = matching({"methods_at_levels": table}, None, 9)
    assert [r["p"] for r in rows] == [0.017, 0.03]  # paired two-sided, Welch one-sided
    assert_allclose([r["size"] for r in rows], [3.0 / 3.0, 2.0 * math.sqrt(2 / 9)], rtol=1e-12)
    protocol = protocols.load_protocol("luidolt2020")
    summary = pd.DataFrame(
        [{"category": "Overall", "n": 5, "wilcoxon_V": 10.0, "p_holm": 0.2, "count_4": 1}]
    )
    (row,) = PARADIGMS["rating"]({"summary": summary}, protocol, 5)
    # four ratings differ from the midpoint; all above it: V = 1 + 2 + 3 + 4, r = 1
    assert (
        row["size"] == 1.0 and row["p"] == 0.2 and row["effect"] == "Wilcoxon Overall vs 4 (Holm)"
    )
