import csv
import re
import shutil

import numpy as np
import pandas as pd
import pytest

from glarelab.analysis.load import DataError, load_sessions
from glarelab.analysis.report import write_report
from glarelab.analysis.stats import rm_anova
from glarelab.cli import main
from glarelab.protocols import load_protocol


def csvs(folder, study):
    return sorted(folder.glob(f"*_{study}_s*.csv"))


def test_yoshida_report_holds_every_analysis(simulated, tmp_path):
    report = write_report(
        load_protocol("yoshida2008"), csvs(simulated, "yoshida2008"), tmp_path / "report"
    )
    text = report.read_text()
    for table in (
        "anova",
        "methods_at_levels",
        "pairwise_contrasts",
        "similarity_groups",
        "boost",
        "bounds_and_match",
        "questionnaire",
    ):
        assert (tmp_path / "report" / f"{table}.csv").is_file()
        assert (tmp_path / "report" / f"{table}.md").is_file()
        assert f"<code>{table}.csv</code>" in text  # each table's title names its file
    for figure in (
        "bounds_and_match.png",
        "boost.png",
        "participants_matches.png",
    ):
        assert (tmp_path / "report" / figure).stat().st_size > 5000
    assert text.count("data:image/png;base64,") == 3  # without the stimulus set
    assert "given the stimulus set" in text
    anova = pd.read_csv(tmp_path / "report" / "anova.csv")
    assert set(anova["analysis"]) == {
        "6 × 2 (all levels)",
        "3 × 2 ({A, B, C})",
        "3 × 2 ({D, E, F})",
    }
    main_effect = anova[
        (anova["analysis"] == "6 × 2 (all levels)") & (anova["source"] == "L_disk")
    ].iloc[0]
    assert main_effect["df1"] == 5 and main_effect["df2"] == 45  # as the paper's F(5, 45)
    tests = pd.read_csv(tmp_path / "report" / "methods_at_levels.csv")
    assert set(tests["test"]) == {"paired", "Welch"} and len(tests) == 6
    assert (tests.loc[tests["test"] == "paired", "df"] == 9).all()
    boost = pd.read_csv(tmp_path / "report" / "boost.csv")
    assert abs(boost.loc[boost["level"] == "A", "boost_percent_mean"].iloc[0]) < 2  # no glare at A


@pytest.mark.parametrize("study", ["spencer1995", "luidolt2020"])
def test_other_reports(simulated, tmp_path, study):
    report = write_report(load_protocol(study), csvs(simulated, study), tmp_path / "r")
    assert report.read_text().count("data:image/png;base64,") == 2  # results, participants


def test_no_effect_data_are_significant_at_the_nominal_rate():
    # matches drawn with no level or method effect: the GG-corrected main effects should be
    # significant in about 5 % of 300 data sets (binomial 99 % range: 2 %-9 %)
    rng = np.random.default_rng(0)
    hits = {"L_disk": 0, "method": 0}
    for _ in range(300):
        rows = [
            {
                "participant": s,
                "L_disk": str(level),
                "method": method,
                "match_cd_m2": 250 + subject + rng.normal(0, 10),
            }
            for s, subject in enumerate(rng.normal(0, 20, 10))
            for level in range(1, 7)
            for method in ("gaussian", "vos")
        ]
        table = rm_anova(
            pd.DataFrame(rows), "match_cd_m2", ["L_disk", "method"], "participant"
        ).set_index("source")
        for effect in hits:
            hits[effect] += table.loc[effect, "p_gg"] < 0.05
    for effect, count in hits.items():
        assert 0.02 <= count / 300 <= 0.09, (effect, count)


def write_csv(path, text):
    path.write_text(text)
    return path


def test_bad_cells_are_named_by_file_line_and_column(simulated, tmp_path):
    source = csvs(simulated, "yoshida2008")[0]
    lines = source.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[3].split(",")
    cells[header.index("darker_cd_m2")] = "bright"
    lines[3] = ",".join(cells)
    bad = write_csv(tmp_path / "bad.csv", "\n".join(lines) + "\n")
    with pytest.raises(
        DataError, match=r"bad\.csv, line 4, column darker_cd_m2: 'bright' is not a number"
    ):
        load_sessions(load_protocol("yoshida2008"), [bad])


def test_missing_column_other_study_duplicates_and_unbalanced(simulated, tmp_path):
    source = csvs(simulated, "yoshida2008")[0]
    text = source.read_text()
    dropped = pd.read_csv(source).drop(columns=["q2_ring"])
    dropped.to_csv(tmp_path / "missing.csv", index=False)
    with pytest.raises(
        DataError,
        match=r"missing\.csv, line 1: columns do not match the yoshida2008 schema; missing \['q2_ring'\]",
    ):
        load_sessions(load_protocol("yoshida2008"), [tmp_path / "missing.csv"])
    with pytest.raises(DataError, match="columns do not match the spencer1995 schema"):
        load_sessions(load_protocol("spencer1995"), [source])
    lines = text.splitlines()
    duplicate = write_csv(tmp_path / "dup.csv", "\n".join([*lines, lines[5]]) + "\n")
    with pytest.raises(
        DataError,
        match=r"dup\.csv, line 17: duplicated trial \(participant sim01, session 1, trial 5\)",
    ):
        load_sessions(load_protocol("yoshida2008"), [duplicate])
    short = write_csv(
        tmp_path / "short.csv", "\n".join(lines[:-2]) + "\n"
    )  # last two main trials lost
    with pytest.raises(
        DataError,
        match=r"participant sim01 has no trial at \{'method': '\w+', 'level_index': \d\}",
    ):
        load_sessions(
            load_protocol("yoshida2008"),
            [short, *csvs(simulated, "yoshida2008")[1:]],
            include_no_sidecar=True,
        )
    dataset = load_sessions(
        load_protocol("yoshida2008"),
        [short, *csvs(simulated, "yoshida2008")[1:]],
        exclude_incomplete=True,
        include_no_sidecar=True,
    )
    assert list(dataset.excluded) == ["sim01"] and "sim01" not in set(
        dataset.trials["participant"]
    )


def test_the_command_exits_non_zero_and_writes_nothing_on_bad_input(simulated, tmp_path, capsys):
    data = pd.read_csv(csvs(simulated, "luidolt2020")[0], keep_default_na=False)
    data.loc[0, "rating"] = 9  # outside the 1-7 scale
    bad = tmp_path / "bad.csv"
    data.to_csv(bad, index=False)
    out = tmp_path / "report"
    assert main(["analyse", "luidolt2020", str(bad), "--out", str(out)]) == 2
    assert "bad.csv, line 2, column rating" in capsys.readouterr().err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".report-")]
    good = [str(p) for p in csvs(simulated, "luidolt2020")]
    assert main(["analyse", "luidolt2020", *good, "--out", str(out)]) == 0
    assert (out / "report.html").is_file()
    shutil.rmtree(out)


def test_files_of_the_first_data_format_still_load(simulated, tmp_path):
    """Before format 0.2 the CSVs had no onset, ignored keys or flash timing columns."""
    added = ["onset_s", "ignored_keys", "offset_s", "shown_ms", "presentation_ok", "counted"]
    old = []
    for path in csvs(simulated, "spencer1995"):
        with path.open(newline="") as handle:
            rows = list(csv.DictReader(handle))
        target = tmp_path / path.name.replace("_2026", "_old_2026")
        kept = [name for name in rows[0] if name not in added]
        with target.open("w", newline="") as handle:
            writer = csv.DictWriter(handle, kept, extrasaction="ignore", lineterminator="\n")
            writer.writeheader()
            writer.writerows(rows)
        old.append(target)
    dataset = load_sessions(load_protocol("spencer1995"), old, include_no_sidecar=True)
    assert dataset.trials["counted"].all()  # every trial of an old file moved its staircase
    assert dataset.trials["onset_s"].isna().all()
    new = load_sessions(load_protocol("spencer1995"), csvs(simulated, "spencer1995"))
    assert len(dataset.trials) == len(new.trials)


@pytest.mark.parametrize(
    ("change", "named"),
    [
        ({"duration_ms": "500.0"}, "column duration_ms: 500.0"),
        ({"step_fraction": "7"}, "column step_fraction: 7.0"),
        ({"presentation_ok": "false", "counted": "true"}, "its presentation failed"),
        (
            {"counted": "false", "presentation_ok": "false", "reversal": "false", "__all__": True},
            "none of their trials counted",
        ),
        ({"counted": "false"}, "not counted, but its presentation succeeded"),
        (
            {"counted": "false", "presentation_ok": "false", "reversal": "true"},
            "a reversal on a flash that did not count",
        ),
        ({"disc_fraction": "0.8500000001"}, "is not on the staircase's grid"),
        ({"block": "lamp", "context": "none"}, "but the trial's context is 'none'"),
    ],
)
def test_staircase_rows_the_protocol_cannot_write_are_refused(simulated, tmp_path, change, named):
    source = csvs(simulated, "spencer1995")[0]
    frame = pd.read_csv(source, keep_default_na=False, dtype=str)
    rows = slice(None) if change.pop("__all__", False) else 3
    for column, value in change.items():
        frame.loc[rows, column] = value
    bad = tmp_path / source.name
    frame.to_csv(bad, index=False)
    shutil.copy(source.with_suffix(".json"), bad.with_suffix(".json"))
    with pytest.raises(DataError, match=re.escape(named)):
        load_sessions(load_protocol("spencer1995"), [bad])


@pytest.mark.parametrize(
    "flag", ["exclude_incomplete", "include_aborted", "include_pilots", "include_no_sidecar"]
)
@pytest.mark.parametrize("value", ["no", 1, None])
def test_load_sessions_refuses_a_flag_that_is_not_a_bool(flag, value, tmp_path):
    """exclude_incomplete='no' is true to `if`: it dropped participants missing a cell, and
    include_pilots='no' analysed pilots as participants."""
    with pytest.raises(TypeError, match=f"^{flag} must be True or False; got {value!r}"):
        load_sessions(load_protocol("spencer1995"), [tmp_path / "x.csv"], **{flag: value})


def test_load_sessions_reads_one_path_as_one_file(tmp_path):
    """A single path string was iterated over its characters ('/: not a file', 'w: no such
    file', ...)."""
    missing = str(tmp_path / "x.csv")
    with pytest.raises(DataError) as error:
        load_sessions(load_protocol("spencer1995"), missing)
    assert len(error.value.problems) == 1 and "x.csv: no such file" in error.value.problems[0]


@pytest.mark.parametrize(
    ("protocol", "paths", "pattern"),
    [
        (
            "spencer1995",
            ["x.csv"],
            r"^protocol must be a Protocol \(load_protocol\('spencer1995'\)",
        ),
        (None, ["x.csv"], "^protocol must be a Protocol .*NoneType"),
        ("P", [None], r"^paths must hold file paths \(str or Path\); got None"),
        ("P", 12, "^paths must be a list of session CSV paths; got 12"),
    ],
)
def test_load_sessions_names_an_argument_of_the_wrong_kind(protocol, paths, pattern):
    protocol = load_protocol("spencer1995") if protocol == "P" else protocol
    with pytest.raises(TypeError, match=pattern):
        load_sessions(protocol, paths)


def test_a_sidecar_nested_too_deeply_is_named_not_a_crash(simulated, tmp_path, capsys):
    """A sidecar of '[' * 100000 stopped analyse with a RecursionError ('a bug in glarelab')."""
    for source in csvs(simulated, "spencer1995"):
        shutil.copy(source, tmp_path)
        shutil.copy(source.with_suffix(".json"), tmp_path)
    files = sorted(tmp_path.glob("*.csv"))
    files[0].with_suffix(".json").write_text("[" * 100000 + "]" * 100000)
    out = tmp_path / "report"
    assert main(["analyse", "spencer1995", *map(str, files), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"{files[0].with_suffix('.json')}: not valid JSON (arrays or objects nested too " in err
    assert "Traceback" not in err and not out.exists()


def test_the_sessions_table_counts_a_session_without_sidecar_from_its_rows(simulated, tmp_path):
    """With --include-no-sidecar the Sessions table printed that session and its trials as
    'nan', and every other session number as '1.0'."""
    import html

    files = csvs(simulated, "yoshida2008")
    data = tmp_path / "data"
    data.mkdir()
    for path in files:
        shutil.copy(path, data / path.name)
        if path != files[0]:
            shutil.copy(path.with_suffix(".json"), data / path.with_suffix(".json").name)
    copies = sorted(str(p) for p in data.glob("*.csv"))
    report = write_report(
        load_protocol("yoshida2008"), copies, tmp_path / "report", include_no_sidecar=True
    )
    text = report.read_text(encoding="utf-8")
    sessions = text[text.index("<h2 id='sessions'>") :]
    cells = [html.unescape(c) for c in re.findall(r"<td[^>]*>(.*?)</td>", sessions)]
    assert not {"nan", "1.0", "15.0"} & set(cells), cells
    row = cells[cells.index(files[0].name) :][:8]
    assert row[:3] == [files[0].name, "sim01", "1"] and "no sidecar" in row and "15" in row, row
