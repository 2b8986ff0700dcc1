"""Tables written as R and JASP read them, as they are.

- Numbers: the shortest text that reads back as the same double (Python's ``repr``, the
  shortest round-trip representation; Steele & White 1990, Gay's dtoa): ``4.6``, not
  ``4.5999999999999996``, and never fewer digits than the double needs; a whole number
  without ``.0`` (``5``, as R's ``write.csv`` writes it).
- Booleans: ``TRUE``/``FALSE``. R's ``read.csv`` (``type.convert``, R 4.2) reads a column of
  ``TRUE``/``FALSE`` (or ``T``/``F``) as logical and ``true``/``false`` or ``True``/``False`` as
  character; JASP reads ``TRUE``/``FALSE`` as a nominal variable of two levels. (0/1 would read
  as integers in R and as a continuous scale in JASP.)
- Missing values: an empty cell, which R reads as ``NA`` in a numeric or logical column and
  JASP as missing.

:func:`participants_wide` is the per-participant table JASP's repeated-measures ANOVA takes:
one row per participant, one column per cell of the within design.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

__all__ = ["INTEGRAL_BELOW", "csv_text", "participants_wide", "r_cell"]

# whole numbers below this are written without ".0" (as R's write.csv writes them); every
# integer up to 2**53 is a double exactly
INTEGRAL_BELOW = 2.0**53


def r_cell(value) -> str:
    """One value as R's ``read.csv`` and JASP read it back.

    Parameters
    ----------
    value
        A number, boolean, string, or a missing value (None, NaN, pandas' NA).

    Returns
    -------
    str
        ``TRUE``/``FALSE`` for a boolean, the shortest round-trip text for a float, ``""`` for a
        missing value, the text of anything else. A text ``NA`` is read back by R as missing,
        quoted or not (its ``na.strings``): no participant's id may be ``NA``
        (:data:`glarelab.experiments.data.MISSING_IDS`); a comment typed as ``NA`` is read as no
        comment.

    Examples
    --------
    >>> [r_cell(v) for v in (True, np.False_, 4.6, np.float64(0.1) * 3, 5.0, None, float("nan"))]
    ['TRUE', 'FALSE', '4.6', '0.30000000000000004', '5', '', '']
    >>> float(r_cell(1 / 3)) == 1 / 3
    True
    """
    if value is None or value is pd.NA or value is pd.NaT:
        return ""
    if isinstance(value, bool | np.bool_):
        return "TRUE" if value else "FALSE"
    if isinstance(value, float | np.floating):
        number = float(value)
        if math.isnan(number):
            return ""
        if math.isinf(number):
            return "Inf" if number > 0 else "-Inf"  # R's spelling
        if number.is_integer() and abs(number) < INTEGRAL_BELOW:
            return str(int(number))  # 5, not 5.0 (a df, a count, a luminance in cd/m²)
        return repr(number)
    if isinstance(value, np.integer):
        return str(int(value))
    return str(value)


def csv_text(table: pd.DataFrame) -> str:
    """A table as CSV text R and JASP read with the right types (:func:`r_cell`).

    Parameters
    ----------
    table
        Any table; its column names become the header row (as text) and every cell is
        written by :func:`r_cell`. The index is not written.

    Returns
    -------
    str
        The CSV text, one line per row after the header, each ending in a newline.

    Examples
    --------
    >>> print(csv_text(pd.DataFrame({"p": [0.05, float("nan")], "holds": [True, False]})), end="")
    p,holds
    0.05,TRUE
    ,FALSE
    """
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow([str(c) for c in table.columns])
    for row in table.itertuples(index=False, name=None):
        writer.writerow([r_cell(v) for v in row])
    return buffer.getvalue()


def participants_wide(
    long: pd.DataFrame,
    value: str,
    factors: Sequence[str],
    *,
    participant: str = "participant",
    prefix: str | None = None,
) -> pd.DataFrame:
    """One row per participant, one column per cell of the within factors (the mean of
    ``value`` in the cell): the table JASP's repeated-measures ANOVA takes.

    Parameters
    ----------
    long
        One row per trial or per participant and cell.
    value
        The dependent variable (a column of ``long``).
    factors
        The within factors, outermost first; a column is named
        ``PREFIX_LEVEL1_LEVEL2…`` (``PREFIX`` defaults to ``value``).
    participant
        The participant column.
    prefix
        The columns' first part.

    Returns
    -------
    pandas.DataFrame
        ``participant`` (in the order of ``long``) and one column per cell that occurs, in the
        sorted order of the levels; a cell a participant lacks is missing.

    Raises
    ------
    ValueError
        For a column ``long`` lacks.

    Examples
    --------
    >>> long = pd.DataFrame({"participant": ["a", "a", "b", "b"], "level": [1, 2, 1, 2],
    ...                      "match": [1.5, 2.0, 1.0, 3.0]})
    >>> participants_wide(long, "match", ["level"])
      participant  match_1  match_2
    0           a      1.5      2.0
    1           b      1.0      3.0
    """
    missing = [c for c in [participant, value, *factors] if c not in long.columns]
    if missing:
        raise ValueError(f"participants_wide: no column {', '.join(missing)} in the table")
    factors = list(factors)
    table = long.pivot_table(index=participant, columns=factors, values=value, aggfunc="mean")
    table = table.reindex(columns=sorted(table.columns))  # the cells that occur, in order
    first = prefix or value
    table.columns = [
        "_".join([first, *(str(v) for v in (cell if isinstance(cell, tuple) else (cell,)))])
        for cell in table.columns
    ]
    order = list(dict.fromkeys(long[participant]))
    return table.reindex(order).rename_axis(participant).reset_index()
