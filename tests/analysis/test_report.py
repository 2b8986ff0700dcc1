"""The report as a results section: numbered figures with captions, the stimuli as the display
showed them, a results paragraph from the numbers, APA tables, provenance per session, and
nothing outside the one HTML file."""

import base64
import io
import json
import re
import shutil
from html import unescape

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from glarelab.analysis import paradigms as analysis_paradigms
from glarelab.analysis.load import DataError
from glarelab.analysis.report import write_report
from glarelab.analysis.stimulus_figures import VerifiedSet, to_srgb8
from glarelab.protocols import load_protocol
from glarelab.stimuli.stimulus_set import cached_stimulus_set, read_png_codes

SCIENTIFIC = re.compile(r"\b\d+(\.\d+)?[eE][+-]?\d+\b")  # 1e+04, 2.5E-3


def csvs(folder, study):
    return sorted(folder.glob(f"*_{study}_s*.csv"))


def without_images(html):
    return re.sub(r"data:image/png;base64,[A-Za-z0-9+/=]+", "data:", html)


def figures(html):
    """(number, title) of every figure, in page order."""
    found = re.findall(r"<b>Figure (\d+)\.</b> <i>([^<]*)\.</i>", html)
    return [(int(n), unescape(t)) for n, t in found]


@pytest.fixture(scope="module")
def yoshida(simulated, tmp_path_factory):
    protocol = load_protocol("yoshida2008")
    stimuli = cached_stimulus_set(protocol, progress=None)  # the set the sessions looked at
    out = tmp_path_factory.mktemp("yoshida") / "report"
    report = write_report(protocol, csvs(simulated, "yoshida2008"), out, stimuli=stimuli)
    return report, stimuli


def test_the_yoshida_report_shows_the_stimuli_and_numbers_its_figures(yoshida):
    report, _ = yoshida
    html = report.read_text()
    found = figures(html)
    assert [n for n, _ in found] == list(range(1, len(found) + 1))
    assert len(found) >= 5
    titles = [t for _, t in found]
    assert titles[:4] == [
        "The references of Method I (Gaussian) as the display showed them",
        "The references of Method II (Vos PSF) as the display showed them",
        "The glare-free targets at their start luminances",
        "Glare profiles of the references",
    ]
    assert "Every participant's matches" in titles
    assert html.count("<img ") == html.count("data:image/png;base64,") == len(found)
    # the stimuli come before the results, under the Method
    assert html.index("id='stimuli'") < html.index("Figure 1.") < html.index("id='results'")
    for number in range(1, 5):
        assert (report.parent / f"stimulus_{number:02d}.png").is_file()
    # every caption says what is plotted, and the result figures the n
    for caption in re.findall(r"</i>([^<]*)</figcaption>", html):
        assert len(caption) > 60, caption
    assert html.count("n = 10 participants") >= 2


def test_the_references_are_shown_pixel_for_pixel_as_the_display_showed_them(yoshida):
    report, stimuli = yoshida
    protocol = load_protocol("yoshida2008")
    shown = VerifiedSet(stimuli, protocol)
    # the luminance shown is the set's own codes decoded: the codes the sessions drew
    codes, bits = read_png_codes(stimuli / "reference_vos_f_10bit.png")
    assert bits == 10
    decoded = shown.calibration.decode(codes)
    luminance = shown.luminance("reference_vos_f")
    assert np.mean(luminance == decoded) > 0.999  # float32 EXR vs float64 at the build
    assert np.all(np.abs(luminance - decoded) <= shown.calibration.step_cd_m2(codes) + 1e-9)
    # the first stimulus figure holds the six references at their own size
    picture = shown.picture("reference_gaussian_A")
    assert picture.shape == (271, 271) and picture.dtype == np.uint8
    html = report.read_text()
    first = re.search(r"data:image/png;base64,([A-Za-z0-9+/=]+)", html).group(1)
    grid = np.asarray(Image.open(io.BytesIO(base64.b64decode(first))).convert("L"))
    assert grid.shape[1] >= 3 * 271 and grid.shape[0] >= 2 * 271
    # the image appears in the grid exactly, one screen pixel per display pixel
    assert _find(grid, picture) is not None


def _find(grid, picture):
    """The position of ``picture`` inside ``grid``, exactly, or None."""
    h, w = picture.shape
    first = picture[0]
    for top in range(grid.shape[0] - h + 1):
        row = grid[top]
        for left in np.flatnonzero(row[: grid.shape[1] - w + 1] == first[0]):
            if np.array_equal(row[left : left + w], first) and np.array_equal(
                grid[top : top + h, left : left + w], picture
            ):
                return top, left
    return None


def test_to_srgb8_encodes_relative_luminance():
    # sRGB (IEC 61966-2-1): 18 % grey is 118 of 255, 1 % is 25
    assert to_srgb8(np.array([0.0, 1.0, 18.0, 100.0]), 100.0).tolist() == [0, 25, 118, 255]
    assert to_srgb8(np.array([0.0, 200.0]), 100.0).tolist() == [0, 255]  # above white: clipped


def test_the_results_paragraph_and_tables_read_as_a_paper(yoshida):
    report, _ = yoshida
    html = report.read_text()
    results = (report.parent / "results.md").read_text()
    assert "6 × 2 repeated-measures ANOVA" in results
    assert re.search(r"the main effect of level was (not )?significant, F\(\d", results)
    assert re.search(r"η²p = \.\d\d", results)
    assert "Greenhouse–Geisser" in results and "ε < .75" in results
    assert re.search(r"t\(9\) = -?\d+\.\d\d, p [=<>] ", results)
    for paragraph in results.split("\n\n"):
        assert paragraph.strip() and paragraph.strip() in unescape(html)
    text = without_images(html)
    assert not SCIENTIFIC.search(text), SCIENTIFIC.search(text)
    assert "nan" not in re.sub(r"<[^>]+>", " ", text).split()
    numbers = re.findall(r"<b>Table (\d+)\.</b>", html)
    # the boost test, effect sizes, means, assumptions among them
    assert [int(n) for n in numbers] == list(range(1, 12))
    # p-values as APA writes them in the tables: no leading zero, < .001
    cells = [unescape(c) for c in re.findall(r"<td class='num'>([^<]*)</td>", html)]
    assert "< .001" in cells and not [c for c in cells if c.startswith("0.0") and len(c) > 6]


def test_the_report_is_one_file_with_nothing_outside(yoshida):
    report, _ = yoshida
    html = without_images(report.read_text())
    assert not re.search(r"(src|href)\s*=\s*['\"](?!#|data:)", html)
    assert "http://" not in html and "https://" not in html and "<script" not in html
    moved = report.parent.parent / "alone.html"
    shutil.copy(report, moved)  # a copy on its own holds every image
    assert moved.read_text().count("data:image/png;base64,") >= 5


def test_every_session_has_its_provenance(yoshida, simulated):
    report, _ = yoshida
    origin = json.loads((report.parent / "provenance.json").read_text())
    assert len(origin["sessions"]) == 10 == len(csvs(simulated, "yoshida2008"))
    protocol = load_protocol("yoshida2008")
    assert origin["simulated"] is True
    html = report.read_text()
    sessions = html[html.index("id='sessions'") : html.index("id='provenance'")]
    # a table wider than the page is shown in parts, each with every session's row
    parts = sessions.split("<table>")[1:]
    tables = [re.findall(r"<tr>(<td>.*?)</tr>", part) for part in parts]
    assert all(len(rows) == 10 for rows in tables)
    for index, record in enumerate(origin["sessions"]):
        row = "".join(rows[index] for rows in tables)
        cells = [unescape(c) for c in re.findall(r"<td>(.*?)</td>", row)]
        assert record["file"] in cells and "completed" in cells and "yes" in cells
        assert f"{protocol.sha256[:12]} ✓" in cells  # the protocol this report analysed
        assert any(c.endswith(" ✓") and c != f"{protocol.sha256[:12]} ✓" for c in cells)


def test_a_changed_or_foreign_stimulus_set_is_refused(yoshida, simulated, tmp_path):
    _, stimuli = yoshida
    changed = tmp_path / "changed"
    shutil.copytree(stimuli, changed)
    (changed / "reference_vos_f.exr").write_bytes(b"not an image")
    protocol = load_protocol("yoshida2008")
    with pytest.raises(DataError, match=r"reference_vos_f\.exr: changed"):
        write_report(protocol, csvs(simulated, "yoshida2008"), tmp_path / "r", stimuli=changed)
    spencer = cached_stimulus_set(load_protocol("spencer1995"), progress=None)
    with pytest.raises(DataError, match="built from the spencer1995 protocol"):
        write_report(protocol, csvs(simulated, "yoshida2008"), tmp_path / "r", stimuli=spencer)
    assert not (tmp_path / "r").exists()


def test_the_spencer_report_shows_the_glare_images_of_every_context(simulated, tmp_path):
    protocol = load_protocol("spencer1995")
    stimuli = cached_stimulus_set(protocol, progress=None)
    report = write_report(protocol, csvs(simulated, "spencer1995"), tmp_path, stimuli=stimuli)
    html = report.read_text()
    titles = [t for _, t in figures(html)]
    assert titles == [
        "The glare images of context none as the display showed them",
        "The glare images of context lamp as the display showed them",
        "Glare profiles of the glare images",
        "Matched disc intensity at each glare level",
        "Every participant's matches",
    ]
    results = (tmp_path / "results.md").read_text()
    # 10 participants for 11 df: decided on the lower bound, the uncorrected test beside it
    assert "lower-bound corrected, ε = 1/11: sphericity not estimable" in results
    assert "uncorrected F(11, 99)" in results
    assert not SCIENTIFIC.search(without_images(html))


def test_the_rating_report_has_a_visible_neutral_category_and_every_participant(
    simulated, tmp_path
):
    protocol = load_protocol("luidolt2020")
    report = write_report(protocol, csvs(simulated, "luidolt2020"), tmp_path)
    html = report.read_text()
    assert [t for _, t in figures(html)] == ["Ratings per category", "Every participant's ratings"]
    assert "grey: the neutral 4" in html
    # a questionnaire shows no images: no stimulus set to give (every way to give one is
    # refused), so the report does not ask for one
    assert "--stimuli SET" not in html
    results = (tmp_path / "results.md").read_text()
    assert "Wilcoxon signed-rank tests, Holm-corrected across the 6 categories" in results
    # the neutral bar is drawn in a grey that differs from white and from its neighbours
    from glarelab.analysis.rating import NEUTRAL, _colours

    colours = _colours(range(1, 8))
    assert len(colours) == 7 and tuple(colours[3][:3]) != (1.0, 1.0, 1.0)
    grey = np.array(Image.open(tmp_path / "ratings.png").convert("RGB"))
    target = np.round(255 * np.array(_rgb(NEUTRAL))).astype(int)
    assert (np.abs(grey.astype(int) - target).sum(axis=2) < 6).sum() > 200  # visible area


def _rgb(colour):
    import matplotlib.colors

    return matplotlib.colors.to_rgb(colour)


def test_a_paradigm_may_show_its_own_stimuli(simulated, tmp_path, monkeypatch):
    """The contract for a paradigm without a stimulus set (a rendered scene that was rated):
    ``result["stimuli"]``, a list of mappings with png, title and caption."""
    module = analysis_paradigms.PARADIGMS["rating"]
    original = module.analyse
    buffer = io.BytesIO()
    Image.fromarray(np.full((40, 60), 90, np.uint8)).save(buffer, format="PNG")

    def analyse(dataset, protocol):
        result = original(dataset, protocol)
        result["stimuli"] = [
            {"title": "The scene that was rated", "png": buffer.getvalue(), "caption": "A test."}
        ]
        return result

    monkeypatch.setattr(module, "analyse", analyse)
    protocol = load_protocol("luidolt2020")
    report = write_report(protocol, csvs(simulated, "luidolt2020"), tmp_path)
    html = report.read_text()
    assert figures(html)[0] == (1, "The scene that was rated")
    assert "width='60' height='40'" in html
    assert (tmp_path / "stimulus_01.png").read_bytes() == buffer.getvalue()
    assert html.index("Figure 1.") < html.index("id='results'") < html.index("Figure 2.")


@pytest.mark.parametrize("study", ["yoshida2008", "spencer1995"])
def test_one_participant_gets_a_report_that_says_why_there_are_no_tests(
    simulated, tmp_path, study
):
    protocol = load_protocol(study)
    report = write_report(protocol, csvs(simulated, study)[:1], tmp_path)
    results = (tmp_path / "results.md").read_text()
    assert results.startswith("With 1 participant no inferential statistics can be computed")
    for text in (results, re.sub(r"<[^>]+>", " ", without_images(report.read_text()))):
        # "SEM nan" was printed, and an unbounded slope as "-inf"
        assert not {"nan", "inf"} & set(re.findall(r"[\w.]+", text.lower())), text


@pytest.mark.parametrize(
    ("comment", "cell"),
    [
        ("left | right looked the same", r"left \| right looked the same"),
        ("line one\nline two", "line one<br>line two"),
        ("line one\r\nline two", "line one<br>line two"),
    ],
)
def test_a_comment_stays_in_its_markdown_cell(comment, cell):
    # a '|' split the comment into another cell, a line break ended the table's row
    import pandas as pd

    from glarelab.analysis.report import _markdown

    text = _markdown(pd.DataFrame({"participant": ["sim01"], "comment": [comment]}))
    lines = text.splitlines()
    assert len(lines) == 3 and lines[2] == f"| sim01 | {cell} |"
    assert [line.replace(r"\|", "").count("|") for line in lines] == [3, 3, 3]


def _rendered_cell(comment: str) -> str:
    """The comment's cell of a report's Markdown table as a Markdown viewer shows it
    (CommonMark with tables and strikethrough, raw HTML on, as GitHub and editors render)."""
    import pandas as pd
    from markdown_it import MarkdownIt

    from glarelab.analysis.report import _markdown

    viewer = MarkdownIt("commonmark", {"html": True}).enable(["table", "strikethrough"])
    shown = viewer.render(_markdown(pd.DataFrame({"comment": [comment]})))
    (cell,) = re.findall(r"<td>(.*?)</td>", shown, re.S)
    return unescape(cell.replace("<br>", "\n"))


@pytest.mark.parametrize(
    "comment",
    ["<script>alert(1)</script>", "<img src=x onerror=alert(1)>", "**bold** [link](http://evil)",
     "&lt; is an entity", "__init__", "`code`", "~~gone~~", "<http://a.b>", "![i](x.png)",
     "p < .001", "a_b_c", "5 > 3 * 2"],
)  # fmt: skip
def test_a_comment_is_shown_as_typed_not_as_markup(comment):
    """A participant's ``<script>…`` reached comments.md as raw HTML (run or dropped by a
    Markdown viewer), and ``**bold**`` or a link was formatted: only '|' was escaped."""
    pytest.importorskip("markdown_it")
    assert _rendered_cell(comment) == comment


@settings(max_examples=300, deadline=None)
@given(
    st.text(
        alphabet=st.characters(codec="utf-8", categories=["L", "N", "P", "S", "Zs"])
        | st.sampled_from("<>&*_`[]()~|\\!#;/\n"),
        max_size=40,
    )
)
def test_every_comment_is_shown_as_typed(comment):
    pytest.importorskip("markdown_it")
    typed = "\n".join(line.strip() for line in comment.splitlines()).strip()
    shown = "\n".join(line.strip() for line in _rendered_cell(comment).splitlines()).strip()
    assert shown == typed


@pytest.mark.parametrize("study", ["yoshida2008", "luidolt2020"])
def test_a_report_is_written_under_a_locale_that_is_not_utf8(simulated, tmp_path, study):
    """Under LANG=C (or Windows' cp1252) the tables and texts, with η, ∞ and −, ended the
    analysis in a bare codec error: every file is written as UTF-8 whatever the locale."""
    import os
    import subprocess
    import sys

    files = [str(f) for f in sorted(simulated.glob(f"*_{study}_s1_*.csv"))]
    env = {k: v for k, v in os.environ.items() if not k.startswith(("LC_", "LANG", "PYTHONUTF8"))}
    env |= {"LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0"}
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "analyse", study, *files, "--out", str(tmp_path / "r")],
        capture_output=True,
        text=True,
        encoding="utf-8",
        errors="replace",
        env=env,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    text = (tmp_path / "r" / "results.md").read_text(encoding="utf-8")
    assert "η" in text or "−" in text or "∞" in text or "Holm" in text


def test_one_participants_ratings_are_not_tested_in_the_tables_either(simulated, tmp_path):
    """The results said 'no test' for one participant while the tables gave each category a
    Wilcoxon V, p = 1 and intervals at the level 0."""
    import pandas as pd

    files = sorted(simulated.glob("*_luidolt2020_s1_*.csv"))[:1]
    out = write_report(load_protocol("luidolt2020"), files, tmp_path / "r").parent
    summary = pd.read_csv(out / "summary.csv")
    assert summary["p"].isna().all() and summary["wilcoxon_V"].isna().all()
    assert summary["test"].str.contains("one participant").all()
