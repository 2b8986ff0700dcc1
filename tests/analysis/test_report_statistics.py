"""What a reviewer reads in the reports: the Holm family holds only the tests that could be
computed (as R's wilcox.test + p.adjust), the comparisons' conclusions follow the corrected
family, effect sizes come with intervals, the tables keep every digit, and data that leave
nobody to analyse are refused with a line that says so."""

import copy
import dataclasses
import json
import re
import shutil
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from glarelab.analysis.load import DataError, Dataset, load_sessions
from glarelab.analysis.paradigms import PARADIGMS
from glarelab.protocols import load_protocol

from .test_stats import read_r

CATEGORIES = ["Glare Appearance", "Overall", "Brightness", "Realism"]


def questionnaire(ratings: dict[str, list[int]]) -> Dataset:
    """The rating study's trials for the issue's questionnaire (R: holm_family.csv)."""
    rows = []
    for category, values in ratings.items():
        for index, value in enumerate(values):
            rows.append(
                {
                    "participant": f"p{index + 1}",
                    "category": category,
                    "rating": value,
                    "comment": None,
                    "block": "main",
                }
            )
    return Dataset(study="luidolt2020", trials=pd.DataFrame(rows), files=[])


@pytest.fixture
def protocol():
    protocol = load_protocol("luidolt2020")
    data = copy.deepcopy(protocol.data)  # the loaded protocol is not changed
    data["questionnaire"]["categories"] = CATEGORIES
    return dataclasses.replace(protocol, data=data)


def test_a_category_everyone_rated_at_the_midpoint_is_left_out_of_the_family(protocol):
    theirs = read_r("holm_family.csv")
    ratings = {
        c: [int(v) for v in r.split(";")]
        for c, r in zip(theirs["category"], theirs["ratings"], strict=True)
    }
    result = PARADIGMS["rating"].analyse(questionnaire(ratings), protocol)
    summary = result["tables"]["summary"]
    assert_allclose(summary["p"], theirs["p"], rtol=1e-9)  # NaN where R has NA
    assert_allclose(summary["p_holm"], theirs["p_holm"], rtol=1e-9)
    assert summary.loc[0, "test"] == "not computed: every rating at the midpoint"
    text = result["results"][0]
    assert "No test could be computed for Glare Appearance (every rating at the midpoint" in text
    assert "Holm-corrected across the 3 categories that could be tested" in text
    assert "the Holm family holds the 3 computed tests" in text
    assert "Luidolt (2020, §7.2.1) reports the mean rating of each category" in text
    assert "Glare Appearance (Mdn = 4, IQR = 0; M = 4.00, SD = 0.00) was not tested" in text


def test_two_categories_keep_rs_decision_on_overall(protocol):
    """The issue's case: R's Holm p for Overall is .0385 ("differed"), not .077."""
    data = copy.deepcopy(protocol.data)
    data["questionnaire"]["categories"] = CATEGORIES[:2]
    protocol = dataclasses.replace(protocol, data=data)
    ratings = {"Glare Appearance": [4] * 8, "Overall": [7, 5, 3, 6, 6, 6, 6, 4]}
    result = PARADIGMS["rating"].analyse(questionnaire(ratings), protocol)
    overall = result["tables"]["summary"].set_index("category").loc["Overall"]
    assert_allclose(overall["p_holm"], 0.038506040175992767, rtol=1e-9)
    assert (
        "Overall (Mdn = 6, IQR = 1.25; M = 5.38, SD = 1.30) differed from the midpoint"
        in (result["results"][0])
    )
    # HL as R's wilcox.test(conf.int = TRUE): 5.99996 - 4 on the ratings off the midpoint,
    # [4.49999862, 6.50006451] - 4 (the Walsh median of every rating is 1.5)
    assert re.search(
        r"r_rb = \.89, HL shift = 2\.00, 95 % CI \[0\.50, 2\.50\]", result["results"][0]
    )


@pytest.fixture(scope="module")
def yoshida_report(simulated, tmp_path_factory):
    from glarelab.analysis.report import write_report

    out = tmp_path_factory.mktemp("yoshida") / "report"
    files = sorted(simulated.glob("*yoshida2008*.csv"))
    write_report(load_protocol("yoshida2008"), files, out)
    return out


def test_the_methods_comparisons_follow_the_holm_family_and_label_the_papers_test(yoshida_report):
    tests = pd.read_csv(yoshida_report / "methods_at_levels.csv")
    paired = tests[tests["test"] == "paired"]
    adjusted = np.minimum(1, np.maximum.accumulate(np.sort(paired["p_two_sided"].to_numpy())
                                                   * np.arange(len(paired), 0, -1)))  # fmt: skip
    assert_allclose(np.sort(paired["p_holm"].to_numpy()), adjusted, rtol=1e-12)
    text = (yoshida_report / "results.md").read_text()
    comparisons = text.split("\n\n")[1]
    for row in paired.itertuples():
        verdict = "differed" if row.p_holm < 0.05 else "did not differ"
        assert f"at {row.level} the matches" in comparisons
        assert re.search(rf"at {row.level} the matches[^;]*{verdict}, t\(9\)", comparisons)
    assert "(the paper's test, uncorrected;" in comparisons
    assert re.search(r"d_z = -?\d\.\d\d, \d\d(\.\d)? % CI \[-?\d\.\d\d, -?\d\.\d\d\]", comparisons)
    for row in paired.itertuples():  # each interval agrees with the corrected test beside it
        excludes = row.md_ci_low > 0 or row.md_ci_high < 0
        assert excludes == (row.p_holm < 0.05), row
    assert re.search(r"η²p = \.\d\d, 90 % CI \[\.\d\d, \.\d\d\], η²G = \.\d\d", text)
    assert "On the levels {A, B, C} alone" in text


def test_the_report_csvs_hold_every_digit(yoshida_report):
    anova = (yoshida_report / "anova.csv").read_text().splitlines()[1].split(",")
    header = (yoshida_report / "anova.csv").read_text().splitlines()[0].split(",")
    f_text = anova[header.index("F")]
    # every digit the double needs, and no more (R's write.csv keeps 15)
    assert f_text == repr(float(f_text)) and float(f"{float(f_text):.15g}") != float(f_text)
    table = pd.read_csv(yoshida_report / "anova.csv")
    assert float(f_text) == table["F"].iloc[0]


def test_a_study_other_than_the_papers_does_not_quote_its_tests(simulated, yoshida_report):
    text = (yoshida_report / "results.md").read_text()
    assert "Yoshida et al. (2008) report" in text
    protocol = load_protocol("yoshida2008")
    dataset = load_sessions(protocol, sorted(simulated.glob("*yoshida2008*.csv")))
    # the same design, another study that does not ask for the paper's own tests
    analysis = {**protocol.data["analysis"], "quote_welch_tests": False}
    other = dataclasses.replace(
        protocol, study="other2026", data={**protocol.data, "analysis": analysis}
    )
    joined = " ".join(PARADIGMS["matching"].analyse(dataset, other)["results"])
    assert "Yoshida et al. (2008) report" not in joined
    assert "comparison with published values" not in joined


def _dry_sessions(simulated, tmp_path, status="aborted"):
    """Copies of two simulated sessions cut to their first three (training) trials."""
    files = []
    for source in sorted(simulated.glob("*yoshida2008*.csv"))[:2]:
        target = tmp_path / source.name
        target.write_text("\n".join(source.read_text().splitlines()[:4]) + "\n")
        sidecar = json.loads(source.with_suffix(".json").read_text())
        sidecar |= {"status": status, "trials": 3, "row_sha256": sidecar["row_sha256"][:3]}
        sidecar["runs"][-1] |= {"status": status, "trials_after": 3}  # as a session writes it
        target.with_suffix(".json").write_text(json.dumps(sidecar))
        files.append(target)
    return files


def test_training_only_sessions_are_refused_by_name_not_with_a_keyerror(simulated, tmp_path):
    files = _dry_sessions(simulated, tmp_path)
    with pytest.raises(DataError, match=r"participant sim01 has no trial at \{'method'"):
        load_sessions(load_protocol("yoshida2008"), files, include_aborted=True)
    with pytest.raises(DataError, match=r"every participant \(2\) misses a cell of the design"):
        load_sessions(
            load_protocol("yoshida2008"), files, include_aborted=True, exclude_incomplete=True
        )


def test_the_command_says_why_on_dry_run_data(simulated, tmp_path):
    files = _dry_sessions(simulated, tmp_path)
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "analyse", "yoshida2008", *map(str, files),
         "--out", str(tmp_path / "report"), "--include-aborted", "--exclude-incomplete"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert done.returncode not in (0, 70), done.stderr  # 70: a bug in glarelab
    assert "KeyError" not in done.stderr
    assert "nothing is left to analyse" in done.stderr
    assert not (tmp_path / "report").exists()
    shutil.rmtree(tmp_path, ignore_errors=True)
