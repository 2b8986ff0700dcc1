"""scripts/yoshida_seeds.py: seeded studies as the demo runs them, summarised next to Yoshida
2008 §5 (a quick form: two seeds of four observers)."""

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

SCRIPT = Path(__file__).parents[1] / "scripts" / "yoshida_seeds.py"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("yoshida_seeds", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_two_seeded_studies_give_every_statistic(script, tmp_path, capsys):
    out = tmp_path / "seeds"
    assert script.main(["--seeds", "2", "--participants", "4", "--out", str(out)]) == 0
    frame = pd.read_csv(out / "yoshida_seeds.csv")
    assert list(frame["seed"]) == [1, 2]
    assert list(frame["participants"]) == [4, 4]
    for key in script.STATISTICS:
        assert np.isfinite(frame[key]).all(), key
        assert ((frame[f"p_{key}"] >= 0) & (frame[f"p_{key}"] <= 1)).all(), key
    assert (frame["level"] > 1).all()  # glare raises the matches in every study
    statistics = frame[list(script.STATISTICS)].to_numpy()
    assert (statistics[0] != statistics[1]).all()  # each seed its own observers and noise
    text = (out / "yoshida_seeds.md").read_text()
    assert "| L_disk × method, F(5, 45) | 7.77, p < .001 |" in text
    assert text in capsys.readouterr().out
    assert (out / "yoshida_seeds.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(out.glob(".*.partial"))
    # the summary of the CSV alone is the same
    again = tmp_path / "again"
    assert script.main(["--summarise", str(out / "yoshida_seeds.csv"), "--out", str(again)]) == 0
    assert (again / "yoshida_seeds.md").read_text() == text


def test_the_summary_reads_the_distribution(script):
    # 101 seeds whose F is the seed itself: median 51, 5 % and 95 % points 6 and 96
    seeds = np.arange(1, 102)
    frame = pd.DataFrame({"seed": seeds})
    for key in script.STATISTICS:
        frame[key] = seeds.astype(float)
        frame[f"p_{key}"] = np.where(seeds <= 20, 0.01, 0.5)
        frame[f"p_gg_{key}"] = np.where(seeds <= 10, 0.01, 0.5)
    summary = script.summarise(frame).set_index("statistic")
    assert_allclose(summary.loc["method", ["median", "p05", "p95"]].astype(float), [51, 6, 96])
    assert_allclose(summary.loc["method", "significant"], 20 / 101, rtol=1e-12)
    assert_allclose(summary.loc["method", "significant_gg"], 10 / 101, rtol=1e-12)
    # the paper's F(1, 9) = 1.64: one seed (F = 1) lies below it
    assert_allclose(summary.loc["method", "paper_percentile"], 100 / 101, rtol=1e-12)
    assert summary.loc["level", "demo"] == 1.0


@pytest.mark.parametrize(
    "effect, key",
    [
        ("6 × 2 (all levels): L_disk", "level"),
        ("6 × 2 (all levels): L_disk × method", "interaction"),
        ("3 × 2 ({D, E, F}): method", "method_DEF"),
        ("3 × 2 ({A, B, C}): L_disk × method", "interaction_ABC"),
        ("3 × 2 ({A, B, C}): L_disk", None),
        ("t-test E/e: gaussian > vos (Welch, one-sided)", "t_E"),
        ("t-test E/e: gaussian > vos (paired, two-sided)", None),
    ],
)
def test_effects_are_named_as_the_analysis_names_them(script, effect, key):
    assert script._key(effect) == key


def test_bad_options_are_refused(script, capsys):
    with pytest.raises(SystemExit):
        script.main(["--seeds", "0"])
    assert "--seeds must be >= 1; got 0" in capsys.readouterr().err


def test_the_papers_pattern_of_significance_is_counted(script):
    paper = {f"p_{k}": 0.01 if script.PAPER_P[k] != "n.s." else 0.5 for k in script.STATISTICS}
    frame = pd.DataFrame([paper, {**paper, "p_method": 0.01}, {**paper, "p_t_D": 0.9}])
    # the first matches, the second has a significant method effect, the third differs
    # only in a t-test (not one of the seven F tests)
    assert_allclose(script.pattern_rate(frame), 2 / 3, rtol=1e-12)


def test_the_docs_show_the_committed_studies(script, tmp_path):
    root = SCRIPT.parents[1]
    committed = root / "docs" / "observers"
    assert (
        script.main(["--summarise", str(committed / "yoshida_seeds.csv"), "--out", str(tmp_path)])
        == 0
    )
    table = (tmp_path / "yoshida_seeds.md").read_text()
    assert table == (committed / "yoshida_seeds.md").read_text()
    assert table in (root / "docs" / "observers.md").read_text()
    frame = pd.read_csv(committed / "yoshida_seeds.csv")
    assert len(frame) >= 100 and (frame["participants"] == 10).all()
    summary = script.summarise(frame).set_index("statistic")
    readme = " ".join((root / "README.md").read_text().split())
    for key, df in (("level", "F(5, 45)"), ("interaction", "F(5, 45)"), ("method_DEF", "F(1, 9)")):
        row = summary.loc[key]
        numbers = f"{df} = {row['median']:.1f} [{row['p05']:.1f}, {row['p95']:.1f}]"
        assert f"{numbers}, {100 * row['significant']:.0f} %" in readme, key
