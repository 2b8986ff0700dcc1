"""Numbers as a results section prints them: the correction rule, the effect strings, and
tables with fixed decimals, APA p-values and never scientific notation."""

import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.analysis import apa
from glarelab.analysis.apa import (
    anova_effect,
    apa_F,
    apa_t,
    format_table,
    header,
    p_cell,
    significant,
    unit_interval,
)
from glarelab.analysis.stats import correction, rm_anova

SCIENTIFIC = re.compile(r"\d[eE][+-]?\d")
P_CELL = re.compile(r"^(< \.001|> \.999|\.\d{3}|)$")

finite = st.floats(min_value=-1e9, max_value=1e9, allow_nan=False, allow_infinity=False)


def _row(df1, eps_gg, eps_hf, sphericity="estimated"):
    return pd.Series(
        {
            "df1": df1,
            "df2": 9.0 * df1,
            "F": 4.2,
            "p": 0.004,
            "eps_gg": eps_gg,
            "p_gg": 0.03,
            "eps_hf": eps_hf,
            "p_hf": 0.02,
            "eta2_partial": 0.318,
            "sphericity": sphericity,
        }
    )


@settings(max_examples=200, deadline=None)
@given(df1=st.integers(1, 20), eps=st.floats(0.05, 1.0))
def test_the_correction_follows_the_rule_and_the_df_are_corrected(df1, eps):
    row = _row(float(df1), eps, min(1.0, eps + 0.1))
    chosen = correction(row)
    text = anova_effect(row)
    if df1 == 1:
        assert chosen == "none" and text.startswith("F(1, 9) = 4.20, p = .004, η²p = .32")
        assert "corrected" not in text
    elif eps < 0.75:
        assert chosen == "GG" and "(Greenhouse–Geisser corrected, ε = " in text
        assert text.startswith(f"F({dof(df1 * eps)}, {dof(9 * df1 * eps)}) = 4.20, p = .030")
    else:
        assert chosen == "HF" and "(Huynh–Feldt corrected, ε = " in text
        hf = min(1.0, eps + 0.1)
        assert text.startswith(f"F({dof(df1 * hf)}, {dof(9 * df1 * hf)}) = 4.20, p = .020")


def dof(x):
    """Degrees of freedom as APA prints them: a float a hair from a whole number is that number
    (20 × 0.05000000000000001 is 1)."""
    return f"{round(x):.0f}" if abs(x - round(x)) < 1e-9 * max(1.0, abs(x)) else f"{x:.2f}"


def test_an_effect_whose_sphericity_is_not_estimable_is_decided_on_the_lower_bound():
    row = _row(11.0, float("nan"), float("nan"), "not estimable: 10 subjects for 11 df")
    row["eps_lb"], row["p_lb"] = 1 / 11, 0.071
    assert correction(row) == "LB"
    assert anova_effect(row) == (
        "F(1, 9) = 4.20, p = .071, η²p = .32 (lower-bound corrected, ε = 1/11: sphericity not "
        "estimable: 10 subjects for 11 df; uncorrected F(11, 99) = 4.20, p = .004)"
    )


def test_effects_from_a_real_anova_name_their_correction():
    rng = np.random.default_rng(3)
    rows = [
        {"s": s, "level": level, "v": level * (1 + s) + rng.normal(0, 1 + level)}
        for s in range(8)
        for level in range(5)
    ]
    table = rm_anova(pd.DataFrame(rows), "v", "level", "s")
    text = anova_effect(table.iloc[0])
    eps = table.loc[0, "eps_gg"]
    assert ("Greenhouse–Geisser" in text) == (eps < 0.75)
    assert re.search(r"η²p = \.\d\d", text)


@settings(max_examples=200, deadline=None)
@given(p=st.floats(0.0, 1.0))
def test_p_cells_are_as_apa_writes_them(p):
    cell = p_cell(p)
    assert P_CELL.match(cell), cell
    if p < 0.001:
        assert cell == "< .001"


@settings(max_examples=300, deadline=None)
@given(
    columns=st.lists(
        st.tuples(
            st.sampled_from(["p", "p_holm", "F", "df2", "eta2_partial", "match_mean", "x"]),
            st.lists(st.one_of(finite, st.just(float("nan"))), min_size=1, max_size=8),
        ),
        min_size=1,
        max_size=4,
        unique_by=lambda c: c[0],
    )
)
def test_formatted_tables_have_no_scientific_notation_and_apa_p_values(columns):
    length = min(len(values) for _, values in columns)
    data = {}
    for name, values in columns:
        values = np.array(values[:length])
        if name.startswith("p"):
            values = np.abs(values) / (1 + np.abs(values))  # into [0, 1)
        if name == "eta2_partial":
            values = np.clip(np.abs(values), 0, 1)
        data[name] = values
    table = pd.DataFrame(data)
    formatted = format_table(table)
    for name in formatted.columns:
        for cell in formatted[name]:
            assert not SCIENTIFIC.search(cell), (name, cell)
            if name.startswith("p"):
                assert P_CELL.match(cell), (name, cell)
    if "x" in data:  # a column of measurements keeps one number of decimals
        values = data["x"][np.isfinite(data["x"])]
        nonzero = np.abs(values[values != 0])
        log_spaced = nonzero.size and np.log10(nonzero.max()) - np.log10(nonzero.min()) > 3
        shown = [c for c in formatted["x"] if c]
        decimals = {len(c.split(".")[1]) if "." in c else 0 for c in shown}
        if not log_spaced:
            assert len(decimals) <= 1, shown


def test_a_mean_and_its_sem_share_decimals_and_strengths_keep_their_digits():
    table = pd.DataFrame(
        {
            "lower_mean": [205.31, 274.8],
            "lower_sem": [7.69, 14.02],
            "strength": [0.01, 284.0],
            "l_disk_cd_m2": [220.0, 10000.0],
            "apa": ["F(1, 9) = 2.00, p = .191", "t(9) = 1.00, p = .343"],
        }
    )
    formatted = format_table(table)
    assert formatted["lower_mean"].tolist() == ["205.3", "274.8"]
    assert formatted["lower_sem"].tolist() == ["7.7", "14.0"]
    assert formatted["strength"].tolist() == ["0.01", "284"]
    assert formatted["l_disk_cd_m2"].tolist() == ["220", "10,000"]
    assert "apa" not in formatted  # the results text quotes these
    assert header("lower_sem") == "lower SEM" and header("l_disk_cd_m2") == "L_disk (cd/m²)"


@settings(max_examples=300, deadline=None)
@given(value=st.floats(1e-6, 1e9), digits=st.integers(1, 5))
def test_significant_digits_round_trip(value, digits):
    text = significant(value, digits)
    assert not SCIENTIFIC.search(text)
    back = float(text.replace(",", ""))
    assert back == pytest.approx(value, rel=0.5 * 10 ** (1 - digits) * 1.0001)


@pytest.mark.parametrize(
    ("value", "decimals", "text"),
    [
        (0.6912, 2, ".69"),
        (0.999, 2, ".999"),  # APA: a value below 1 never printed as 1
        (0.9999, 2, "> .999"),
        (1.0, 3, "1.000"),
        (-0.049, 2, "-.05"),
        (0, 2, ".00"),
    ],
)
def test_unit_interval_drops_the_leading_zero_below_one(value, decimals, text):
    assert unit_interval(value, decimals) == text


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: apa.apa_p(True), r"^apa_p: p must be a number in \[0, 1\]; got True"),
        (lambda: apa.apa_p("0.03"), r"^apa_p: p must be a number in \[0, 1\]; got '0.03'"),
        (lambda: apa.apa_t(-1, 2.0, 0.05), r"^apa_t: dof: degrees of freedom must be a finite"),
        (lambda: apa.apa_F(2, 0, 3.0, 0.05), r"^apa_F: df2: degrees of freedom must be a finite"),
        (lambda: apa.apa_F(True, 5, 3.0, 0.05), r"^apa_F: df1: degrees of freedom"),
        (lambda: apa.number(1.5, -1), r"^number: decimals must be a whole number 0-20; got -1"),
    ],
)
def test_an_impossible_statistic_is_refused_not_printed(call, match):
    """``apa_p(True)`` printed 'p > .999', ``apa_t(-1, ...)`` 't(-1) = 2.00', ``apa_F(2, 0, ...)``
    'F(2, 0) = 3.00', and ``number(1.5, -1)`` ended in Python's format error."""
    with pytest.raises(ValueError, match=match):
        call()


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (
            lambda: apa_F(2, 18, np.nan, 0.5),
            r"^apa_F: f_value must be a finite number >= 0; got nan",
        ),
        (
            lambda: apa_F(2, 18, -3.0, 0.5),
            r"^apa_F: f_value must be a finite number >= 0; got -3.0",
        ),
        (lambda: apa_F(2, 18, np.inf, 0.0), r"^apa_F: f_value .* got inf"),
        (lambda: apa_F(2, 18, "3", 0.0), r"^apa_F: f_value .* got '3'"),
        (lambda: apa_t(10, np.inf, 0.0), r"^apa_t: t must be a finite number; got inf"),
        (lambda: apa_t(10, np.nan, 0.5), r"^apa_t: t must be a finite number; got nan"),
        (lambda: apa_t(10, True, 0.5), r"^apa_t: t must be a finite number; got True"),
    ],
)
def test_the_formatters_refuse_a_statistic_that_is_not_a_finite_number(call, pattern):
    """'F(2, 18) = nan', 'F(2, 18) = -3.00' and 't(10) = inf' were printed."""
    with pytest.raises(ValueError, match=pattern):
        call()


@pytest.mark.parametrize("digits", [0, -1, 2.0, True, "3", None])
def test_significant_digits_that_are_no_count_are_refused(digits):
    with pytest.raises(ValueError, match=r"^digits must be a whole number >= 1"):
        apa.significant(1.0, digits)


@pytest.mark.parametrize("value", [-0.004, -0.0, -0.00499, 0.004])
def test_a_unit_interval_that_rounds_to_zero_has_no_sign(value):
    assert apa.unit_interval(value) == ".00"
