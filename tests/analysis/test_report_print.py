"""Report tables a reader cannot misread and figures ready for print: each corrected p beside
the p it corrects, wide tables shown in parts that repeat the columns naming their rows, and
every figure as PDF and SVG beside its PNG with no text below 8 pt at a page's width."""

from __future__ import annotations

import re

import matplotlib.text
import pandas as pd
import pytest

from glarelab.analysis.figures import (
    MIN_PRINTED_PT,
    PRINT_WIDTH_IN,
    legible,
    png,
    printed_scale,
    subplots,
)
from glarelab.analysis.report import SPLIT_COLUMNS, column_parts, corrected_beside


@pytest.mark.parametrize("study", ["yoshida2008", "luidolt2020"])  # spencer1995: no Holm family
def test_the_holm_p_is_beside_the_p_it_corrects(reports, study):
    found = 0
    for path in reports[study].glob("*.csv"):
        header = path.read_text().splitlines()[0].split(",")
        if "p_holm" in header:
            found += 1
            base = "p" if "p" in header else "p_two_sided"
            assert header.index("p_holm") == header.index(base) + 1, (path.name, header)
        page = (reports[study] / "report.html").read_text()
        assert "p (Holm)" in page or not found
    assert found, study


def test_corrected_beside_keeps_every_column():
    table = pd.DataFrame(columns=["a", "p_two_sided", "p_one_sided", "x", "p_holm"])
    assert corrected_beside(table).columns.tolist() == [
        "a", "p_two_sided", "p_holm", "p_one_sided", "x"
    ]  # fmt: skip
    assert corrected_beside(pd.DataFrame(columns=["t", "p"])).columns.tolist() == ["t", "p"]


def test_a_wide_table_is_shown_in_parts_that_name_their_rows(reports):
    page = (reports["yoshida2008"] / "report.html").read_text()
    anova = pd.read_csv(reports["yoshida2008"] / "anova.csv")
    assert len(anova.columns) > SPLIT_COLUMNS
    table_1 = page.split("id='table-1'")[1].split("id='table-2'")[0]
    parts = table_1.split("<table>")[1:]
    assert len(parts) >= 2 and "Part 1 of" in table_1
    for part in parts:  # each part repeats the analysis and the effect
        heads = re.findall(r"<th[^>]*>([^<]*)</th>", part)
        assert heads[:2] == ["analysis", "source"], heads
        assert len(heads) <= SPLIT_COLUMNS
    # every column is in one part (the keys in all)
    shown = {h for part in parts for h in re.findall(r"<th[^>]*title='([^']*)'", part)}
    assert shown == {c for c in anova.columns if not c.startswith("apa")}
    sessions = page.split("id='sessions'")[1]
    assert "Part 1 of" in sessions


def test_column_parts_split_evenly_and_keep_the_keys():
    table = pd.DataFrame([["a"] + [1.0] * 20], columns=["key"] + [f"c{i}" for i in range(20)])
    parts = column_parts(table, width=6)
    assert all(part[0] == "key" and len(part) <= 6 for part in parts)
    assert sum(len(part) - 1 for part in parts) == 20


@pytest.mark.parametrize("study", ["yoshida2008", "spencer1995", "luidolt2020"])
def test_every_figure_has_its_pdf_and_svg(reports, study):
    pngs = sorted(reports[study].glob("*.png"))
    assert pngs
    for path in pngs:
        assert path.with_suffix(".pdf").read_bytes().startswith(b"%PDF"), path.name
        assert b"<svg" in path.with_suffix(".svg").read_bytes()[:2000], path.name


def test_no_text_prints_below_8_pt_at_a_pages_width():
    figure, axes = subplots(1, 5, figsize=(13, 2.5))  # drawn twice a page's width
    for axis in axes:
        axis.plot([0, 1], [0, 1], label="a line")
        axis.set_xlabel("level", fontsize=9)
        axis.set_title("method", fontsize=10)
        axis.legend(fontsize=7)
    legible(figure)
    figure.draw_without_rendering()
    scale = printed_scale(figure)
    assert scale == pytest.approx(PRINT_WIDTH_IN / 13)
    texts = [t for t in figure.findobj(matplotlib.text.Text) if t.get_text() and t.get_visible()]
    assert len(texts) > 20  # tick labels among them
    smallest = min(t.get_fontsize() for t in texts) * scale
    assert smallest >= MIN_PRINTED_PT - 1e-9
    rendered = png(figure)
    assert rendered.pdf.startswith(b"%PDF") and b"<svg" in rendered.svg[:2000]
    assert bytes(rendered).startswith(b"\x89PNG")


@pytest.mark.parametrize("study", ["yoshida2008", "spencer1995", "luidolt2020"])
def test_an_interval_is_headed_with_its_own_confidence(reports, study):
    # Yoshida's effect sizes: η²p intervals are 90 %, never headed 95 %
    from glarelab.analysis.apa import header

    for path in reports[study].glob("*.csv"):
        table = pd.read_csv(path)
        heads = [header(str(c)) for c in table.columns]
        # the intervals at the row's confidence (r_rb's is 95 % always, and headed so)
        at_row = {"ci_low", "ci_high", "md_ci_low", "md_ci_high", "dz_ci_low", "dz_ci_high"}
        if "confidence" in table.columns and (table["confidence"].dropna() != 0.95).any():
            governed = [h for c, h in zip(table.columns, heads, strict=True) if c in at_row]
            assert not any("95 %" in h for h in governed), (path.name, governed)
        for column, head in zip(table.columns, heads, strict=True):
            if str(column).startswith("eta2p_ci"):
                assert "90 % CI" in head, (path.name, column, head)
        if "effect_size" in table.columns:
            eta = table[table["effect_size"] == "η²p"]
            assert (eta["confidence"] == 0.90).all(), path.name
