"""The report's CSVs read into R and JASP as they are: booleans R reads as logical, numbers in
the shortest text that gives back the same double, and a per-participant wide table.

R's own reading is checked by tests/analysis/R/exports.R (run here where Rscript is installed):
every column's type, and a repeated-measures ANOVA on the wide table that gives the report's F.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab.analysis.export import csv_text, participants_wide, r_cell

R_SCRIPT = Path(__file__).parent / "R" / "exports.R"
RSCRIPT = shutil.which("Rscript")
NO_R = "Rscript is not installed (apt-get install r-base-core); exports.R is not run"


def _significant(text: str) -> int:
    mantissa = text.lstrip("+-").split("e")[0].split("E")[0].replace(".", "")
    return len(mantissa.strip("0")) or 1


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_a_number_is_written_in_the_fewest_digits_that_give_it_back(value):
    text = r_cell(value)
    assert float(text) == value
    digits = _significant(text)
    if digits > 1:  # one digit fewer is another double
        assert float(f"{value:.{digits - 1}g}") != value, text


def test_the_issues_numbers_and_booleans():
    # docs of the issue: 4.6 was written 4.5999999999999996; true/false read as text in R
    assert r_cell(4.6) == "4.6"
    assert r_cell(np.float64(4.6)) == "4.6"
    assert r_cell(5.0) == "5"
    assert r_cell(True) == "TRUE" and r_cell(np.bool_(False)) == "FALSE"
    assert r_cell(float("inf")) == "Inf"
    assert r_cell(pd.NA) == "" and r_cell(float("nan")) == ""
    table = pd.DataFrame({"holds": [True, False], "p": [4.6, 1 / 3]})
    assert csv_text(table) == "holds,p\nTRUE,4.6\nFALSE,0.3333333333333333\n"


def test_the_wide_table_has_a_row_per_participant_and_a_column_per_cell():
    long = pd.DataFrame(
        {
            "participant": ["b", "b", "b", "a", "a", "a"],
            "method": ["x", "x", "y", "y", "x", "x"],
            "level": [2, 1, 1, 1, 1, 2],
            "match": [4.0, 3.0, 5.0, 6.0, 1.0, 2.0],
        }
    )
    wide = participants_wide(long, "match", ["method", "level"])
    assert list(wide.columns) == ["participant", "match_x_1", "match_x_2", "match_y_1"]
    assert wide["participant"].tolist() == ["b", "a"]
    assert_allclose(wide.iloc[:, 1:].to_numpy(float), [[3, 4, 5], [1, 2, 6]], rtol=0)
    with pytest.raises(ValueError, match="no column rating"):
        participants_wide(long, "rating", ["method"])


def test_the_report_writes_trials_and_the_wide_table_r_reads(reports):
    report = reports["yoshida2008"]
    trials = (report / "trials.csv").read_text().splitlines()
    header = trials[0].split(",")
    first = dict(zip(header, trials[1].split(","), strict=True))
    assert first["q1_glow"] in ("TRUE", "FALSE")
    assert first["file"].endswith(".csv") and "/" not in first["file"]
    assert "_line" not in header and "_file" not in header
    wide = pd.read_csv(report / "participants_wide.csv")
    table = pd.read_csv(report / "trials.csv")
    main = table[table["block"] == "main"]
    assert len(wide) == main["participant"].nunique() == 10
    assert len(wide.columns) == 1 + 12  # participant, 2 methods × 6 levels
    one = main[(main["participant"] == wide["participant"][0]) & (main["method"] == "vos")]
    expected = one.sort_values("level_index")["match_cd_m2"].to_numpy(float)
    assert_allclose(wide.filter(like="_vos_").iloc[0].to_numpy(float), expected, rtol=0)
    for study, folder in reports.items():
        for path in folder.glob("*.csv"):
            text = path.read_text()
            for word in (",true,", ",false,", ",True,", ",False,"):
                assert word not in text, (study, path.name, word)
    # every number of every table in its shortest text
    anova = (report / "anova.csv").read_text().splitlines()
    cells = [c for line in anova[1:] for c in line.split(",")]
    numbers = [c for c in cells if c.replace(".", "").replace("-", "").isdigit()]
    assert numbers
    for cell in numbers:
        assert r_cell(float(cell)) == cell


@pytest.mark.skipif(RSCRIPT is None, reason=NO_R)
@pytest.mark.parametrize("study", ["yoshida2008", "spencer1995", "luidolt2020"])
def test_r_reads_the_exports_with_the_right_types(reports, study):
    done = subprocess.run(
        [RSCRIPT, str(R_SCRIPT), str(reports[study]), study],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("ok")
    if study == "yoshida2008":
        assert "F(L_disk × method)" in done.stdout


@pytest.mark.skipif(RSCRIPT is None, reason=NO_R)
def test_the_r_script_refuses_what_r_misreads(reports, tmp_path):
    # the writing the report had: lowercase booleans, 17 significant digits
    folder = tmp_path / "old"
    shutil.copytree(reports["yoshida2008"], folder)
    table = pd.read_csv(folder / "trials.csv")
    table.loc[0, "time_s"] = 4.6
    text = table.to_csv(index=False, float_format="%.17g").replace("True", "true")
    (folder / "trials.csv").write_text(text.replace("False", "false"))
    done = subprocess.run(
        [RSCRIPT, str(R_SCRIPT), str(folder), "yoshida2008"],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode != 0
    assert "booleans written true, which R reads as text" in done.stderr
    assert "4.5999999999999996 is written with more digits" in done.stderr
