"""Numbers as a results section prints them (APA, 7th edition): effects with their corrected
degrees of freedom and effect size, p-values, and tables with fixed decimals.

The test strings (``F(5, 45) = 23.68, p < .001``), each ANOVA effect with the degrees of
freedom of the correction :func:`glarelab.analysis.stats.correction` chooses and its effect
sizes, and whole tables for reading (the CSV files keep every digit). This module formats;
it computes no statistic.

References
----------
American Psychological Association (2020), *Publication Manual*, 7th ed., §6.36-6.44 (numbers,
statistics), §7.8-7.21 (tables).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import get_args

import numpy as np
import pandas as pd

from glarelab.analysis.stats import GG_BELOW, Correction, correction
from glarelab.files.values import is_whole

__all__ = [
    "anova_effect",
    "apa_F",
    "apa_anova",
    "apa_p",
    "apa_t",
    "format_table",
    "header",
    "number",
    "p_cell",
    "series",
    "significant",
    "unit_interval",
]

CORRECTION_NAMES = {"GG": "Greenhouse–Geisser", "HF": "Huynh–Feldt", "LB": "lower-bound"}
# columns whose values cannot exceed 1 in magnitude: no leading zero (APA §6.36)
UNIT_INTERVAL_DECIMALS = {
    "eta2_partial": 2,
    "eta2_generalized": 2,
    "eta2p_ci_low": 2,
    "eta2p_ci_high": 2,
    "eps_gg": 3,
    "eps_hf": 3,
    "eps_lb": 3,
    "mauchly_W": 3,
    "r_rb": 2,
    "rb_ci_low": 2,
    "rb_ci_high": 2,
    "shapiro_W": 3,
}
STATISTICS = {
    "F",
    "t",
    "V",
    "wilcoxon_V",
    "mean_difference",
    "md_ci_low",
    "md_ci_high",
    "d_z",
    "dz_ci_low",
    "dz_ci_high",
}  # two decimals
# columns of log-spaced values (the glare strengths), printed with significant digits; any
# other column gets one number of decimals, however far its values spread
LOG_SPACED = {"strength"}
HEADERS = {
    "eta2_partial": "η²p",
    "eta2_generalized": "η²G",
    "eta2p_ci_low": "η²p 90 % CI low",
    "eta2p_ci_high": "η²p 90 % CI high",
    "md_ci_low": "M diff CI low",  # at the table's confidence level (Holm-compatible)
    "md_ci_high": "M diff CI high",
    "d_z": "d_z",
    "dz_ci_low": "d_z CI low",
    "dz_ci_high": "d_z CI high",
    "ci_low": "CI low",
    "ci_high": "CI high",
    "confidence": "CI level",
    "hl_ci_low": "HL CI low",
    "hl_ci_high": "HL CI high",
    "hl_confidence": "HL CI level",
    "MSE": "MSE",
    "r_rb": "r_rb",
    "rb_ci_low": "r_rb 95 % CI low",
    "rb_ci_high": "r_rb 95 % CI high",
    "hl_shift": "HL shift",
    "reversals_low": "lowest reversal",
    "reversals_high": "highest reversal",
    "shapiro_W": "Shapiro–Wilk W",
    "shapiro_p": "p (Shapiro–Wilk)",
    "sem_within": "SEM (within)",
    "eps_gg": "ε (GG)",
    "eps_hf": "ε (HF)",
    "eps_lb": "ε (LB)",
    "p_gg": "p (GG)",
    "p_hf": "p (HF)",
    "p_lb": "p (LB)",
    "p_holm": "p (Holm)",
    "p_two_sided": "p (two-sided)",
    "p_one_sided": "p (one-sided)",
    "mauchly_W": "Mauchly's W",
    "mauchly_p": "p (Mauchly)",
    "wilcoxon_V": "V",
    "sd": "SD",
    "iqr": "IQR",
    "n": "n",
    "l_disk_cd_m2": "L_disk (cd/m²)",  # Yoshida et al.'s symbol
}
WORDS = {  # abbreviations in headings
    "sem": "SEM",
    "sd": "SD",
    "se": "SE",
    "iqr": "IQR",
    "ci": "95 % CI",
    "within": "± (within)",
}


def apa_p(p: float) -> str:
    """``p < .001``, ``p = .034`` or ``p > .999`` (APA: three decimals, no leading zero).

    Parameters
    ----------
    p
        The p-value, in [0, 1].

    Returns
    -------
    str
        The text.

    Raises
    ------
    ValueError
        For a p that is NaN or outside [0, 1] (a test that could not be computed has no p to
        print; say why instead).

    Examples
    --------
    >>> apa_p(0.0341), apa_p(0.0004), apa_p(0.9996)
    ('p = .034', 'p < .001', 'p > .999')
    """
    try:
        value = float("nan") if isinstance(p, bool | np.bool_ | str) else float(p)
    except (TypeError, ValueError):
        value = float("nan")
    if not 0 <= value <= 1:
        plain = isinstance(p, int | float | np.floating) and not isinstance(p, bool)
        shown = value if plain else repr(p)
        raise ValueError(f"apa_p: p must be a number in [0, 1]; got {shown}")
    if value < 0.001:
        return "p < .001"
    text = f"{value:.3f}"
    if text == "1.000":  # p >= .9995 would round to 1
        return "p > .999"
    return f"p = {text[1:]}"


def fixed(value: float, decimals: int) -> str:
    """A number with fixed decimals, never a negative zero (``-0.004`` is ``0.00``: a sign
    the printed digits do not carry).

    Examples
    --------
    >>> fixed(-0.004, 2), fixed(-0.006, 2), fixed(3.14159, 1)
    ('0.00', '-0.01', '3.1')
    """
    text = f"{float(value):.{decimals}f}"
    return text.removeprefix("-") if float(text) == 0 else text


def _dof(value: object, name: str) -> float:
    """Degrees of freedom as a number above 0, else a ValueError naming them."""
    number = isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool | np.bool_
    )
    if not (number and math.isfinite(value) and value > 0):
        raise ValueError(
            f"{name}: degrees of freedom must be a finite number above 0; got {value!r}"
        )
    return float(value)


def _statistic(value: object, name: str, *, low: float = -math.inf) -> float:
    """A test statistic as a finite number >= ``low``, else a ValueError naming it (a test
    that could not be computed has no statistic to print)."""
    number = isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool | np.bool_
    )
    if not (number and math.isfinite(value) and value >= low):
        allowed = "a finite number" + (f" >= {low:g}" if math.isfinite(low) else "")
        raise ValueError(
            f"{name} must be {allowed}; got {value!r} (a test that could not be computed has "
            "no statistic to print; say why instead)"
        )
    return float(value)


def degrees(value: float) -> str:
    """Degrees of freedom: whole ones as integers, corrected (fractional) ones with two
    decimals; ``1 / 11 × 11`` is 1 (a float a hair from a whole number is that number).

    Raises
    ------
    ValueError
        For degrees of freedom that are not a finite number above 0.

    Examples
    --------
    >>> degrees(45.0), degrees(21.148), degrees(11 * (1 / 11))
    ('45', '21.15', '1')
    """
    value = _dof(value, "degrees")
    if abs(value - round(value)) < 1e-9 * max(1.0, abs(value)):
        return f"{round(value):.0f}"
    return f"{value:.2f}"


def apa_F(df1: float, df2: float, f_value: float, p: float) -> str:
    """``F(5, 45) = 23.68, p < .001``; non-integer df (corrected) get two decimals.

    Parameters
    ----------
    df1, df2
        The numerator's and denominator's degrees of freedom (fractional when corrected).
    f_value
        The F statistic.
    p
        Its p-value, in [0, 1].

    Returns
    -------
    str
        The text.

    Raises
    ------
    ValueError
        For degrees of freedom that are not finite numbers above 0, an F that is negative,
        NaN or infinite, or a p outside [0, 1].

    Examples
    --------
    >>> apa_F(5, 45, 23.684, 0.00001)
    'F(5, 45) = 23.68, p < .001'
    """
    _dof(df1, "apa_F: df1"), _dof(df2, "apa_F: df2")
    f_value = _statistic(f_value, "apa_F: f_value", low=0.0)
    return f"F({degrees(df1)}, {degrees(df2)}) = {fixed(f_value, 2)}, {apa_p(p)}"


def percent(level: float) -> str:
    """A confidence level as a percentage with as few decimals as show it (at most four),
    never rounded up to 100.

    Examples
    --------
    >>> percent(0.95), percent(0.975), percent(1 - 0.05 / 3), percent(0.99996)
    ('95', '97.5', '98.3', '99.996')
    """
    for decimals in range(1, 5):
        text = f"{100 * level:.{decimals}f}"
        if float(text) < 100:
            return text.rstrip("0").rstrip(".")
    return f"{100 * level:.4f}"


def interval(low: float, high: float, decimals: int, *, unit: bool = False) -> str:
    """``[low, high]`` with the same decimals for both limits; ``unit``: values bounded by 1
    in magnitude, without the leading zero, with a third decimal where two would show a
    limit that is not 0 as .00 or one below 1 as 1.00 (never ``[.00, .00]`` for ``[0,
    .003]``, nor ``[.99, .999]``).

    Examples
    --------
    >>> interval(-0.9, -0.004, 1), interval(0.0, 0.003, 2, unit=True)
    ('[-0.9, 0.0]', '[.000, .003]')
    >>> interval(0.986, 0.9991, 2, unit=True), interval(0.1, 0.4, 2, unit=True)
    ('[.986, .999]', '[.10, .40]')
    """
    if not unit:
        return f"[{fixed(low, decimals)}, {fixed(high, decimals)}]"
    values = [float(low), float(high)]
    while decimals < 3 and any(
        (v != 0 and round(abs(v), decimals) == 0) or (abs(v) < 1 and round(abs(v), decimals) >= 1)
        for v in values
    ):
        decimals += 1
    texts = []
    for v in values:
        if v != 0 and round(abs(v), decimals) == 0:
            texts.append("< .001" if v > 0 else "> -.001")
        else:
            texts.append(unit_interval(v, decimals))
    return f"[{texts[0]}, {texts[1]}]"


def confidence_interval(low: float, high: float, decimals: int, level: float, **unit) -> str:
    """``95 % CI [low, high]`` (:func:`interval`, :func:`percent`).

    Examples
    --------
    >>> confidence_interval(-6.94, 51.37, 1, 0.95), confidence_interval(1.2, 3.4, 2, 0.975)
    ('95 % CI [-6.9, 51.4]', '97.5 % CI [1.20, 3.40]')
    """
    return f"{percent(level)} % CI {interval(low, high, decimals, **unit)}"


def apa_anova(table: pd.DataFrame, *, correction: Correction) -> list[str]:
    """APA strings for the rows of an ``rm_anova`` table, uncorrected or corrected.

    Parameters
    ----------
    table
        The result of ``rm_anova``.
    correction
        ``"none"``, ``"GG"`` (Greenhouse–Geisser), ``"HF"`` (Huynh–Feldt) or ``"LB"`` (the
        lower bound ``ε = 1 / df1``): the corrected tests give ``ε df1``, ``ε df2`` and the
        corrected p. Where sphericity is not estimable, GG and HF give the lower-bound test
        with the reason. An effect that could not be tested gives its note.

    Raises
    ------
    ValueError
        For another ``correction``.

    Examples
    --------
    >>> table = pd.DataFrame({"df1": [2.0, 11.0], "df2": [18.0, 77.0], "F": [2.98, 0.66],
    ...     "p": [0.076, 0.772], "eps_gg": [0.943, float("nan")],
    ...     "p_gg": [0.080, float("nan")], "eps_hf": [1.0, float("nan")],
    ...     "p_hf": [0.076, float("nan")], "eps_lb": [0.5, 1 / 11], "p_lb": [0.118, 0.437],
    ...     "sphericity": ["estimated", "not estimable: 8 subjects for 11 df"]})
    >>> apa_anova(table, correction="GG")  # doctest: +NORMALIZE_WHITESPACE
    ['F(1.89, 16.97) = 2.98, p = .080',
     'F(1, 7) = 0.66, p = .437 (lower-bound corrected; sphericity not estimable: 8 subjects
     for 11 df)']
    """
    if correction not in get_args(Correction):
        raise ValueError(
            f"apa_anova: correction must be one of {', '.join(get_args(Correction))}; "
            f"got {correction!r}"
        )
    strings = []
    for _, row in table.iterrows():
        if not math.isfinite(float(row["F"])):
            strings.append(f"no test ({row.get('note', '')})")
            continue
        suffix = correction.lower()
        if correction == "none" or float(row["df1"]) <= 1:
            strings.append(apa_F(row["df1"], row["df2"], row["F"], row["p"]))
            continue
        eps, p = float(row[f"eps_{suffix}"]), float(row[f"p_{suffix}"])
        if math.isnan(eps):
            eps, p = float(row["eps_lb"]), float(row["p_lb"])
            strings.append(
                f"{apa_F(row['df1'] * eps, row['df2'] * eps, row['F'], p)} (lower-bound "
                f"corrected; sphericity {row['sphericity']})"
            )
        else:
            strings.append(apa_F(row["df1"] * eps, row["df2"] * eps, row["F"], p))
    return strings


def apa_t(dof: float, t: float, p: float) -> str:
    """``t(14) = 1.71, p = .054``; Welch's fractional df with one decimal.

    Parameters
    ----------
    dof
        The degrees of freedom (fractional for Welch's test).
    t
        The t statistic.
    p
        Its p-value, in [0, 1].

    Returns
    -------
    str
        The text.

    Raises
    ------
    ValueError
        For degrees of freedom that are not a finite number above 0, a t that is NaN or
        infinite, or a p outside [0, 1].

    Examples
    --------
    >>> apa_t(9, -0.004, 0.997), apa_t(16.83, 1.7749, 0.048)
    ('t(9) = 0.00, p = .997', 't(16.8) = 1.77, p = .048')
    """
    dof = _dof(dof, "apa_t: dof")
    t = _statistic(t, "apa_t: t")
    d = f"{dof:.0f}" if dof.is_integer() else f"{dof:.1f}"
    return f"t({d}) = {fixed(t, 2)}, {apa_p(p)}"


def unit_interval(value: float, decimals: int = 2) -> str:
    """A value that cannot exceed 1 in magnitude, without the leading zero.

    Parameters
    ----------
    value
        The value, at most 1 in magnitude (a correlation, an effect size, a proportion).
    decimals
        Decimals; default 2 (more where a value below 1 would round to 1, at most 3).

    Returns
    -------
    str
        The text; empty for NaN or infinity.

    Examples
    --------
    >>> unit_interval(0.6912), unit_interval(0.4217, 3), unit_interval(1.0), unit_interval(-0.05)
    ('.69', '.422', '1.00', '-.05')
    >>> unit_interval(0.996), unit_interval(0.99996)  # never rounded up to 1
    ('.996', '> .999')
    >>> unit_interval(-0.004), unit_interval(-0.0)  # no negative zero
    ('.00', '.00')
    """
    if not math.isfinite(value):
        return ""
    if abs(value) < 1:  # APA: a value below 1 is never printed as 1 (.996 is not 1.00)
        while abs(round(value, decimals)) >= 1 and decimals < 3:
            decimals += 1
        if abs(round(value, decimals)) >= 1:
            return "> .999" if value > 0 else "< -.999"
    if round(value, decimals) == 0:  # -0.004 and -0.0: ".00", not a negative zero
        value = 0.0
    text = f"{value:.{decimals}f}"
    return text.replace("0.", ".", 1) if abs(round(value, decimals)) < 1 else text


def epsilon(value: float) -> str:
    """An ε as the text prints it: two decimals, more where two would put it on the other
    side of the Greenhouse–Geisser/Huynh–Feldt boundary (.749 is not ".75").

    Examples
    --------
    >>> epsilon(0.642), epsilon(0.749), epsilon(0.7496), epsilon(1.0)
    ('.64', '.749', '.7496', '1.00')
    """
    decimals = 2
    while decimals < 6 and (value < GG_BELOW) != (round(value, decimals) < GG_BELOW):
        decimals += 1
    return unit_interval(value, decimals)


def anova_effect(row) -> str:
    """One ``rm_anova`` row as a results section prints it: F with the df of the chosen
    correction (:func:`glarelab.analysis.stats.correction`), p, partial eta squared with its
    interval (from the same df, :func:`glarelab.analysis.effects.with_eta2_ci`), η²G, and
    which correction with its ε; where sphericity is not estimable, the lower-bound test, on
    which the conclusion rests, with the reason and the uncorrected test beside it.

    Parameters
    ----------
    row
        A row of :func:`glarelab.analysis.stats.rm_anova`'s table (a :class:`pandas.Series`).

    Returns
    -------
    str
        The text.

    Examples
    --------
    >>> row = pd.Series({"df1": 5.0, "df2": 45.0, "F": 20.06, "p": 1e-9, "eps_gg": 0.47,
    ...                  "p_gg": 2e-5, "eps_hf": 0.55, "p_hf": 1e-5, "eta2_partial": 0.69,
    ...                  "sphericity": "estimated"})
    >>> anova_effect(row)
    'F(2.35, 21.15) = 20.06, p < .001, η²p = .69 (Greenhouse–Geisser corrected, ε = .47)'
    >>> nan = float("nan")
    >>> row = pd.Series({"df1": 11.0, "df2": 99.0, "F": 2.5, "p": 0.008, "eps_gg": nan,
    ...                  "eps_hf": nan, "eps_lb": 1 / 11, "p_lb": 0.148, "eta2_partial": 0.22,
    ...                  "sphericity": "not estimable: 10 subjects for 11 df"})
    >>> anova_effect(row)  # doctest: +NORMALIZE_WHITESPACE
    'F(1, 9) = 2.50, p = .148, η²p = .22 (lower-bound corrected, ε = 1/11: sphericity not
     estimable: 10 subjects for 11 df; uncorrected F(11, 99) = 2.50, p = .008)'
    """
    if "F" in row.index and not math.isfinite(float(row["F"])):
        return f"no test: {str(row.get('note', '')).removeprefix('not testable: ')}"
    chosen = correction(row)
    eta = f"η²p = {unit_interval(float(row['eta2_partial']))}"
    if "eta2p_ci_low" in row.index and math.isfinite(float(row["eta2p_ci_low"])):
        eta += ", 90 % CI " + interval(
            float(row["eta2p_ci_low"]), float(row["eta2p_ci_high"]), 2, unit=True
        )
    if "eta2_generalized" in row.index:
        eta += f", η²G = {unit_interval(float(row['eta2_generalized']))}"
    if chosen == "none":
        return f"{apa_F(row['df1'], row['df2'], row['F'], row['p'])}, {eta}"
    suffix = chosen.lower()
    eps = float(row[f"eps_{suffix}"])
    test = apa_F(row["df1"] * eps, row["df2"] * eps, row["F"], row[f"p_{suffix}"])
    if chosen == "LB":
        uncorrected = apa_F(row["df1"], row["df2"], row["F"], row["p"])
        return (
            f"{test}, {eta} (lower-bound corrected, ε = 1/{degrees(row['df1'])}: sphericity "
            f"{row['sphericity']}; uncorrected {uncorrected})"
        )
    return f"{test}, {eta} ({CORRECTION_NAMES[chosen]} corrected, ε = {epsilon(eps)})"


def series(items: Sequence[str], conjunction: str = "and") -> str:
    """``a``, ``a and b``, ``a, b, and c`` (APA's serial comma).

    Parameters
    ----------
    items
        The items, in order.
    conjunction
        The word before the last item; default ``'and'``.

    Returns
    -------
    str
        The list as text.

    Examples
    --------
    >>> series(["A"]), series(["A", "B"]), series(["A", "B", "C"], "or")
    ('A', 'A and B', 'A, B, or C')
    """
    items = list(items)
    if len(items) <= 2:
        return f" {conjunction} ".join(items)
    return ", ".join(items[:-1]) + f", {conjunction} " + items[-1]


def p_cell(p: float) -> str:
    """A p-value in a table's p column: ``.034``, ``< .001``, ``> .999``; empty for NaN.

    Parameters
    ----------
    p
        The p-value, in [0, 1]; None or NaN for none.

    Returns
    -------
    str
        The cell.

    Examples
    --------
    >>> p_cell(0.0341), p_cell(0.00002), p_cell(float("nan"))
    ('.034', '< .001', '')
    """
    if p is None or (isinstance(p, float) and math.isnan(p)):
        return ""
    return apa_p(p).removeprefix("p = ").removeprefix("p ")


def number(value: float, decimals: int) -> str:
    """A number with fixed decimals and thousands separators (APA §6.38); NaN empty, an
    infinite one ∞ (a slope the data leave unbounded).

    Parameters
    ----------
    value
        The number; None or NaN for none.
    decimals
        Decimals.

    Returns
    -------
    str
        The text.

    Examples
    --------
    >>> number(10000.0, 0), number(275.349, 1), number(-0.5, 2), number(float("nan"), 2)
    ('10,000', '275.3', '-0.50', '')
    >>> number(-0.004, 2)  # no negative zero
    '0.00'
    >>> number(float("-inf"), 1)
    '-∞'
    """
    if not (isinstance(decimals, int | np.integer) and not isinstance(decimals, bool)) or not (
        0 <= decimals <= 20
    ):
        raise ValueError(f"number: decimals must be a whole number 0-20; got {decimals!r}")
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if math.isinf(value):
        return "-∞" if value < 0 else "∞"
    text = f"{value:,.{decimals}f}"
    return text.removeprefix("-") if float(text.replace(",", "")) == 0 else text


def _decimals(values: np.ndarray) -> int:
    """Decimals giving about three significant digits to a column's typical value, at least
    one (a column of measurements) and at most three."""
    magnitude = np.abs(values[np.isfinite(values) & (values != 0)])
    if magnitude.size == 0:
        return 2
    return int(np.clip(2 - math.floor(math.log10(float(np.median(magnitude)))), 1, 3))


def _spread_of(name: str, columns) -> str | None:
    """The mean column a spread column (``X_sem``, ``X_sd``) belongs to, if the table has it:
    a mean and its spread are printed with the same decimals (APA §6.36)."""
    for suffix in ("_sem", "_sd", "_se", "_ci_within", "_ci_low", "_ci_high"):
        if name.endswith(suffix) and f"{name.removesuffix(suffix)}_mean" in columns:
            return f"{name.removesuffix(suffix)}_mean"
    return None


def _is_p(name: str) -> bool:
    return name == "p" or name.startswith("p_") or name.endswith("_p")


def header(name: str) -> str:
    """A column's heading: a statistic's symbol, or its name with the unit in parentheses.

    Parameters
    ----------
    name
        The column's name (``match_mean_cd_m2``, ``eta2_partial``).

    Returns
    -------
    str
        The heading.

    Examples
    --------
    >>> header("eta2_partial"), header("match_mean_cd_m2"), header("boost_percent_sem")
    ('η²p', 'match mean (cd/m²)', 'boost SEM (%)')
    """
    if name in HEADERS:
        return HEADERS[name]
    unit = ""
    for suffix, symbol in (("_cd_m2", "cd/m²"), ("_percent", "%")):
        if name.endswith(suffix) or f"{suffix}_" in name:
            name, unit = name.replace(suffix, "", 1), f" ({symbol})"
            break
    words = [WORDS.get(word, word) for word in name.split("_")]
    return " ".join(words) + unit


def format_table(table: pd.DataFrame) -> pd.DataFrame:
    """The table as strings for reading: p-values as APA prints them, statistics with two
    decimals, values bounded by 1 without the leading zero, whole numbers as integers, and
    every other column with fixed decimals for about three significant digits.

    Columns named ``apa…`` (the test strings, which the results text quotes) are left out.

    Parameters
    ----------
    table
        A results table, one statistic or measure per column.

    Returns
    -------
    pandas.DataFrame
        The same rows, every cell a string.

    Examples
    --------
    >>> table = pd.DataFrame({"source": ["L_disk"], "df1": [5.0], "F": [20.061],
    ...                       "p": [3e-9], "eta2_partial": [0.6904], "l_disk_cd_m2": [10000.0]})
    >>> format_table(table).iloc[0].tolist()
    ['L_disk', '5', '20.06', '< .001', '.69', '10,000']
    """
    shown = table[[c for c in table.columns if not str(c).startswith("apa")]]
    out = pd.DataFrame(index=shown.index)
    for name in shown.columns:
        column = shown[name]
        if pd.api.types.is_bool_dtype(column) or not pd.api.types.is_numeric_dtype(column):
            out[name] = column.map(lambda v: "" if v is None or v != v else str(v))
            continue
        values = column.to_numpy(float)
        finite = values[np.isfinite(values)]
        if _is_p(str(name)):
            out[name] = [p_cell(v) for v in values]
        elif name in LEVELS:  # .95, .975, .9833: as many decimals as tell the level
            out[name] = ["" if math.isnan(v) else _level(v) for v in values]
        elif name in UNIT_INTERVAL_DECIMALS:
            decimals = UNIT_INTERVAL_DECIMALS[name]
            out[name] = ["" if math.isnan(v) else unit_interval(v, decimals) for v in values]
        elif name in STATISTICS:
            out[name] = [number(v, 2) for v in values]
        elif str(name).startswith("df"):  # corrected or Welch df: two decimals
            out[name] = [number(v, 0 if float(v).is_integer() else 2) for v in values]
        elif finite.size and np.all(finite == np.round(finite)):
            out[name] = [number(v, 0) for v in values]
        elif name in LOG_SPACED and _decades(finite) > 3:  # strengths: significant digits
            out[name] = [significant(v, 3) for v in values]
        else:
            mean = _spread_of(str(name), shown.columns)
            decimals = _decimals(shown[mean].to_numpy(float) if mean else values)
            out[name] = [number(v, decimals) for v in values]
    return out


LEVELS = {"confidence", "hl_confidence"}


def _level(value: float) -> str:
    """A confidence level in a table: two to four decimals, trailing zeros dropped."""
    text = unit_interval(value, 4)
    while text.endswith("0") and len(text.split(".")[-1]) > 2:
        text = text[:-1]
    return text


def _decades(values: np.ndarray) -> float:
    magnitude = np.abs(values[values != 0])
    if magnitude.size == 0:
        return 0.0
    return float(np.log10(magnitude.max()) - np.log10(magnitude.min()))


def significant(value: float, digits: int) -> str:
    """A number to ``digits`` significant digits without trailing zeros, never in scientific
    notation, with thousands separators.

    Parameters
    ----------
    value
        The number.
    digits
        Significant digits, >= 1.

    Returns
    -------
    str
        The text.

    Raises
    ------
    ValueError
        For ``digits`` that are not a whole number >= 1.

    Examples
    --------
    >>> significant(0.0254, 3), significant(0.01, 3), significant(12345.6, 3)
    ('0.0254', '0.01', '12,300')
    """
    if not is_whole(digits) or digits < 1:
        raise ValueError(f"digits must be a whole number >= 1; got {digits!r}")
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    text = np.format_float_positional(
        float(value), precision=digits, unique=False, fractional=False, trim="-"
    )
    sign, text = ("-", text[1:]) if text.startswith("-") else ("", text)
    whole, point, fraction = text.partition(".")
    return f"{sign}{int(whole):,}{point}{fraction}"
