"""Numbers as a results section prints them (APA, 7th edition): effects with their corrected
degrees of freedom and effect size, p-values, and tables with fixed decimals.

The test strings themselves (``F(5, 45) = 23.68, p < .001``) come from
:mod:`glarelab.analysis.stats`; this module chooses the sphericity correction an effect is reported
with, adds partial eta squared, and formats whole tables for reading (the CSV files keep every
digit).

**Which correction.** Effects with one degree of freedom need none (sphericity holds). For the
others the degrees of freedom are corrected: with Greenhouse–Geisser's ε when ε < .75, with
Huynh–Feldt's otherwise (Girden 1992; Greenhouse–Geisser is conservative when ε is large,
Huynh–Feldt liberal when it is small). Where sphericity cannot be estimated (fewer subjects
than the effect needs) the uncorrected test is printed with the reason.

References
----------
American Psychological Association (2020), *Publication Manual*, 7th ed., §6.36-6.44 (numbers,
statistics), §7.8-7.21 (tables). Girden (1992), *ANOVA: Repeated measures*, Sage, p. 21.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
import pandas as pd
from glarelab.analysis.stats import apa_F, apa_p

__all__ = [
    "GG_BELOW",
    "anova_effect",
    "correction",
    "format_table",
    "header",
    "number",
    "p_cell",
    "series",
    "significant",
    "unit_interval",
]

GG_BELOW = 0.75  # Girden (1992): Greenhouse–Geisser's ε below .75, Huynh–Feldt's above
CORRECTION_NAMES = {"GG": "Greenhouse–Geisser", "HF": "Huynh–Feldt"}
# columns whose values cannot exceed 1 in magnitude: no leading zero (APA §6.36)
UNIT_INTERVAL_DECIMALS = {
    "eta2_partial": 2,
    "eta2_generalized": 2,
    "eta2p_ci_low": 2,
    "eta2p_ci_high": 2,
    "eps_gg": 3,
    "eps_hf": 3,
    "mauchly_W": 3,
    "r_rb": 2,
    "rb_ci_low": 2,
    "rb_ci_high": 2,
    "shapiro_W": 3,
    "confidence": 2,
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
    "md_ci_low": "M diff 95 % CI low",
    "md_ci_high": "M diff 95 % CI high",
    "d_z": "d_z",
    "dz_ci_low": "d_z 95 % CI low",
    "dz_ci_high": "d_z 95 % CI high",
    "r_rb": "r_rb",
    "rb_ci_low": "r_rb 95 % CI low",
    "rb_ci_high": "r_rb 95 % CI high",
    "hl_shift": "HL shift",
    "shapiro_W": "Shapiro–Wilk W",
    "shapiro_p": "p (Shapiro–Wilk)",
    "sem_within": "SEM (within)",
    "eps_gg": "ε (GG)",
    "eps_hf": "ε (HF)",
    "p_gg": "p (GG)",
    "p_hf": "p (HF)",
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


def correction(row) -> Literal["none", "GG", "HF"]:
    """The correction an ``rm_anova`` row is reported with (module docstring).

    ``"none"`` for an effect with one degree of freedom or whose sphericity is not estimable.

    Examples
    --------
    >>> correction(pd.Series({"df1": 5.0, "eps_gg": 0.42, "eps_hf": 0.47}))
    'GG'
    >>> correction(pd.Series({"df1": 5.0, "eps_gg": 0.81, "eps_hf": 1.0}))
    'HF'
    >>> correction(pd.Series({"df1": 1.0, "eps_gg": 1.0, "eps_hf": 1.0}))
    'none'
    """
    if float(row["df1"]) <= 1 or math.isnan(float(row["eps_gg"])):
        return "none"
    return "GG" if float(row["eps_gg"]) < GG_BELOW else "HF"


def unit_interval(value: float, decimals: int = 2) -> str:
    """A value that cannot exceed 1 in magnitude, without the leading zero.

    Examples
    --------
    >>> unit_interval(0.6912), unit_interval(0.4217, 3), unit_interval(1.0), unit_interval(-0.05)
    ('.69', '.422', '1.00', '-.05')
    >>> unit_interval(0.996), unit_interval(0.99996)  # never rounded up to 1
    ('.996', '> .999')
    """
    if not math.isfinite(value):
        return ""
    if abs(value) < 1:  # APA: a value below 1 is never printed as 1 (.996 is not 1.00)
        while abs(round(value, decimals)) >= 1 and decimals < 3:
            decimals += 1
        if abs(round(value, decimals)) >= 1:
            return "> .999" if value > 0 else "< -.999"
    text = f"{value:.{decimals}f}"
    return text.replace("0.", ".", 1) if abs(round(value, decimals)) < 1 else text


def anova_effect(row) -> str:
    """One ``rm_anova`` row as a results section prints it: F with the df of the chosen
    correction, p, partial eta squared, and which correction with its ε.

    Examples
    --------
    >>> row = pd.Series({"df1": 5.0, "df2": 45.0, "F": 20.06, "p": 1e-9, "eps_gg": 0.47,
    ...                  "p_gg": 2e-5, "eps_hf": 0.55, "p_hf": 1e-5, "eta2_partial": 0.69,
    ...                  "sphericity": "estimated"})
    >>> anova_effect(row)
    'F(2.35, 21.15) = 20.06, p < .001, η²p = .69 (Greenhouse–Geisser corrected, ε = .47)'
    """
    chosen = correction(row)
    eta = f"η²p = {unit_interval(float(row['eta2_partial']))}"
    if "eta2p_ci_low" in row.index and math.isfinite(float(row["eta2p_ci_low"])):
        eta += (
            f", 90 % CI [{unit_interval(float(row['eta2p_ci_low']))}, "
            f"{unit_interval(float(row['eta2p_ci_high']))}]"
        )
    if "eta2_generalized" in row.index:
        eta += f", η²G = {unit_interval(float(row['eta2_generalized']))}"
    if chosen == "none":
        test = apa_F(row["df1"], row["df2"], row["F"], row["p"])
        if float(row["df1"]) > 1:  # sphericity not estimable
            return f"{test}, {eta} (uncorrected; sphericity {row['sphericity']})"
        return f"{test}, {eta}"
    suffix = chosen.lower()
    eps = float(row[f"eps_{suffix}"])
    test = apa_F(row["df1"] * eps, row["df2"] * eps, row["F"], row[f"p_{suffix}"])
    return f"{test}, {eta} ({CORRECTION_NAMES[chosen]} corrected, ε = {unit_interval(eps, 2)})"


def corrected_p(row) -> float:
    """The p-value of the correction :func:`correction` chooses."""
    chosen = correction(row)
    return float(row["p"] if chosen == "none" else row[f"p_{chosen.lower()}"])


def series(items: Sequence[str], conjunction: str = "and") -> str:
    """``a``, ``a and b``, ``a, b, and c`` (APA's serial comma).

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

    Examples
    --------
    >>> p_cell(0.0341), p_cell(0.00002), p_cell(float("nan"))
    ('.034', '< .001', '')
    """
    if p is None or (isinstance(p, float) and math.isnan(p)):
        return ""
    return apa_p(p).removeprefix("p = ").removeprefix("p ")


def number(value: float, decimals: int) -> str:
    """A number with fixed decimals and thousands separators (APA §6.38); NaN empty.

    Examples
    --------
    >>> number(10000.0, 0), number(275.349, 1), number(-0.5, 2), number(float("nan"), 2)
    ('10,000', '275.3', '-0.50', '')
    """
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return f"{value:,.{decimals}f}"


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


def _decades(values: np.ndarray) -> float:
    magnitude = np.abs(values[values != 0])
    if magnitude.size == 0:
        return 0.0
    return float(np.log10(magnitude.max()) - np.log10(magnitude.min()))


def significant(value: float, digits: int) -> str:
    """A number to ``digits`` significant digits without trailing zeros, never in scientific
    notation, with thousands separators.

    Examples
    --------
    >>> significant(0.0254, 3), significant(0.01, 3), significant(12345.6, 3)
    ('0.0254', '0.01', '12,300')
    """
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    text = np.format_float_positional(
        float(value), precision=digits, unique=False, fractional=False, trim="-"
    )
    sign, text = ("-", text[1:]) if text.startswith("-") else ("", text)
    whole, point, fraction = text.partition(".")
    return f"{sign}{int(whole):,}{point}{fraction}"
