"""Writing an analysis: a results section to read and paste from, in one self-contained HTML
file, with its tables (CSV, Markdown) and figures (PNG) beside it.

A paradigm's ``analyse(dataset, protocol)`` (:mod:`glarelab.analysis.paradigms`) returns a dict:

``tables``
    name → DataFrame. Written as ``NAME.csv`` (as R and JASP read it:
    :mod:`glarelab.analysis.export`) and ``NAME.md``; shown as numbered
    tables with fixed decimals and p-values as APA prints them
    (:func:`glarelab.analysis.apa.format_table`).
``figures``
    file name → :class:`glarelab.analysis.figures.Figure` (``png``, ``title``, ``caption``: what is
    plotted, the error bars, n). Written under the file name; shown as numbered figures in the
    Results section. Bare PNG bytes are taken too, titled with the file name.
``text``
    key → one APA statement per test (for programs; the report shows ``results``).
``results`` (optional)
    the Results section's paragraphs, generated from the numbers; also written to
    ``results.md``. Without it the statements of ``text`` are listed.
``captions`` (optional)
    table name → the table's title.
``wide`` (optional)
    one row per participant, one column per cell of the within design (the dependent variable
    JASP's repeated-measures ANOVA takes): written as ``participants_wide.csv``.
``stimuli`` (optional)
    a list of what the participants were shown: :class:`glarelab.analysis.figures.Figure`, or
    mappings with ``png`` (bytes), ``title`` and ``caption``. Shown as numbered figures in the
    Method section, before the results, and written as ``stimulus_NN.png``.

Beside the tables the report writes ``trials.csv``: every trial analysed, one row each, as R
and JASP read it (the session file's name in ``file``).

Given the stimulus set's folder (``stimuli=``), the report opens it
(:class:`glarelab.analysis.stimulus_figures.VerifiedSet`: verified, built from this protocol) and,
if the paradigm's module has ``stimulus_figures(protocol, shown)``, adds the figures it returns
(the set's images as the display showed them) after the analysis's own ``stimuli``.

The page holds everything (images as data URLs, no script, no external address), so it can be
mailed or archived as one file. Everything is written to a staging folder next to the
destination and moved into place only when all of it succeeded, so a failing analysis leaves no
partial report behind; an earlier report in the destination is replaced whole, and a folder
holding anything else is refused (:mod:`glarelab.files.folders`).
"""

from __future__ import annotations

import base64
import hashlib
import html
import io
import json
import re
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd
from PIL import Image

from glarelab.analysis.apa import format_table, header
from glarelab.analysis.dataset import DataError, Dataset
from glarelab.analysis.export import csv_text
from glarelab.analysis.figures import Figure, as_figure
from glarelab.analysis.live import live_frames, live_sentence
from glarelab.analysis.load import load_sessions
from glarelab.analysis.methods import provenance, session_rows
from glarelab.analysis.paradigms import paradigm_analysis
from glarelab.files.folders import (
    check_replaceable,
    output_lock,
    replace_folder,
    staging_folder,
)
from glarelab.files.inputs import loads_json
from glarelab.protocols import ROW_DIGESTS_SINCE

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["analyse", "methods_paragraph", "write_report"]

REPORT = "report.html"
EXPORTS = ("trials", "participants_wide")  # the CSVs written beside the tables
COLLAPSE_ROWS = 30  # longer tables are folded (<details>), their title stays visible
# a table with more columns is shown in parts, each repeating the columns that name its rows,
# so that none is scrolled out of a page's width (about 1,100 px of text at 0.85 em)
SPLIT_COLUMNS = 11
KEY_COLUMNS = 3  # at most this many leading text columns name a row
# a corrected p and the p it corrects: shown side by side, whatever order the analysis built
CORRECTED = {"p_holm": ("p", "p_two_sided")}
FLAGS_SHOWN = 5  # longer lists of flagged trials are folded too
STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;max-width:1100px;
 margin:2em auto;padding:0 1em;line-height:1.45;color:#222}
h1{font-size:1.6em;margin-bottom:0.2em}h2{margin-top:1.8em;border-bottom:1px solid #ddd}
.lead{color:#555;margin-top:0}nav{font-size:0.9em;color:#555}nav a{margin-right:1em}
p.results{max-width:52em}
figure{margin:1.5em 0;break-inside:avoid}figure img{max-width:100%;height:auto;display:block}
figcaption{max-width:52em;font-size:0.92em;margin-top:0.4em}
.table-title{margin:1.6em 0 0.3em;font-size:0.95em}
table{border-collapse:collapse;font-size:0.85em;margin:0.3em 0 1em}.wide{overflow-x:auto}
td,th{padding:2px 8px;border-bottom:1px solid #e3e3e3;text-align:left;vertical-align:top}
thead th{border-bottom:2px solid #444;border-top:2px solid #444;background:#fafafa}
td.num,th.num{text-align:right;font-variant-numeric:tabular-nums}td.num{white-space:nowrap}
details{margin:0.3em 0 1em}summary{cursor:pointer;color:#345}
pre{background:#f6f6f6;padding:0.8em;overflow-x:auto;font-size:0.8em}
code{background:#f3f3f3;padding:0 0.2em}.note{color:#555;font-size:0.92em}
@media print{nav{display:none}body{max-width:none}}
"""


# what a Markdown viewer would take for markup in a cell's text, escaped with a backslash
# (CommonMark §2.4): the start of an HTML tag or autolink, an entity, emphasis, code, links
# and strikethrough; a '<' before a space ('p < .001') or an '_' between letters or digits
# ('sim01_yoshida2008') is text already and stays as written
_MARKUP = re.compile(r"[\\|`*\[\]~]|<(?=[A-Za-z/!?])|&(?=#?\w+;)|(?<![^\W_])_|_(?![^\W_])")


def _markdown_cell(value: object) -> str:
    """A table cell's text as Markdown shows it as written, in its cell: markup characters
    escaped (a participant's comment ``<script>…`` or ``**bold**`` is shown, not run or
    formatted), a line break written as ``<br>``."""
    text = _MARKUP.sub(lambda match: "\\" + match.group(), str(value))
    return "<br>".join(text.splitlines()) if ("\n" in text or "\r" in text) else text


def _markdown(table: pd.DataFrame) -> str:
    formatted = format_table(table)
    header_row = (
        "| " + " | ".join(_markdown_cell(header(str(c))) for c in formatted.columns) + " |"
    )
    rule = "| " + " | ".join("---" for _ in formatted.columns) + " |"
    rows = [
        "| " + " | ".join(map(_markdown_cell, row)) + " |"
        for row in formatted.itertuples(index=False)
    ]
    return "\n".join([header_row, rule, *rows]) + "\n"


def analyse(
    protocol: Protocol,
    paths: list[str | Path],
    *,
    exclude_incomplete: bool = False,
    include_aborted: bool = False,
    include_pilots: bool = False,
    include_no_sidecar: bool = False,
    stimuli: Path | None = None,
) -> tuple[Dataset, dict]:
    """Load the sessions of the protocol's study (checked against the stimulus set, if
    given) and run its paradigm's analysis.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol.
    paths
        The session CSVs.
    exclude_incomplete, include_aborted, include_pilots, include_no_sidecar
        As for :func:`glarelab.analysis.load.load_sessions`; default False each.
    stimuli
        The stimulus set's folder, whose hashes the sessions must have recorded; default
        None: not checked.

    Returns
    -------
    dataset : glarelab.analysis.dataset.Dataset
        The validated trials.
    result : dict
        The paradigm's analysis (``tables``, ``figures``, ``text``, ``results``).

    Raises
    ------
    glarelab.analysis.dataset.DataError
        For data the analysis cannot vouch for.
    """
    dataset = load_sessions(
        protocol,
        paths,
        exclude_incomplete=exclude_incomplete,
        include_aborted=include_aborted,
        include_pilots=include_pilots,
        include_no_sidecar=include_no_sidecar,
        stimuli=None if stimuli is None else set_hashes(stimuli),
    )
    return dataset, paradigm_analysis(protocol).analyse(dataset, protocol)


def set_hashes(stimuli: Path) -> dict:
    """The hashes a session records of the stimulus set it ran on: its manifest's sha256 and
    its calibration's readings'.

    Raises
    ------
    glarelab.analysis.dataset.DataError
        For a folder without a readable manifest.
    """
    manifest = Path(stimuli) / "manifest.json"
    try:
        data = manifest.read_bytes()
        readings = (loads_json(data).get("calibration") or {}).get("readings_sha256")
    except (OSError, ValueError, AttributeError) as error:
        raise DataError([f"{manifest}: not a readable stimulus-set manifest ({error})"]) from None
    return {"manifest_sha256": hashlib.sha256(data).hexdigest(), "readings_sha256": readings}


def methods_paragraph(protocol: Protocol, participants: int, simulated: bool | int) -> str:
    """Methods text naming the protocol's actual parameters; ``simulated`` is true when every
    participant was a simulated observer, or the number of them among the participants.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol.
    participants
        The number of participants analysed.
    simulated
        True when every participant was simulated, else the number of simulated ones (0 or
        False: none).

    Returns
    -------
    str
        The paragraph.
    """
    if simulated is True:
        who = f"{participants} simulated observers"
    elif not simulated:
        who = f"{participants} participants"
    else:
        who = f"{participants} participants ({simulated} of them simulated observers)"
    return paradigm_analysis(protocol).methods(protocol, participants, who)


def _displayed(protocol: Protocol, stimuli: Path | None):
    """The stimulus set as the display showed it: verified, and built from this protocol
    (before the sessions are checked against it)."""
    if stimuli is None:
        return None
    from glarelab.analysis.stimulus_figures import VerifiedSet  # colour-science: only here

    return VerifiedSet(stimuli, protocol)


def _stimuli(protocol: Protocol, result: dict, shown) -> list[Figure]:
    """The analysis's own stimuli, then the set's images as the display showed them."""
    figures = [as_figure(item, "stimulus") for item in result.get("stimuli", [])]
    if shown is not None:
        draw = paradigm_analysis(protocol).stimulus_figures
        if draw is not None:
            figures += draw(protocol, shown)
    return figures


def _grid(head: str, body: str) -> str:
    """A table that scrolls sideways on a narrow page instead of widening it."""
    return (
        f"<div class='wide'><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody>"
        "</table></div>"
    )


def corrected_beside(table: pd.DataFrame) -> pd.DataFrame:
    """The table with each corrected p (``p_holm``) right after the p it corrects.

    >>> corrected_beside(pd.DataFrame(columns=["t", "p", "d", "p_holm"])).columns.tolist()
    ['t', 'p', 'p_holm', 'd']
    """
    order = list(table.columns)
    for corrected, bases in CORRECTED.items():
        base = next((b for b in bases if b in order), None)
        if corrected in order and base is not None:
            order.remove(corrected)
            order.insert(order.index(base) + 1, corrected)
    return table[order]


def column_parts(table: pd.DataFrame, *, width: int = SPLIT_COLUMNS) -> list[list]:
    """The columns of each part a wide table is shown in: the leading text columns that name a
    row (at most :data:`KEY_COLUMNS`) in every part, the others ``width`` minus those a part.

    >>> columns = ["method", "level"] + [f"x{i}" for i in range(12)]
    >>> table = pd.DataFrame([["a", "b"] + [1.0] * 12], columns=columns)
    >>> [len(part) for part in column_parts(table, width=8)]
    [8, 8]
    """
    columns = list(table.columns)
    if len(columns) <= width:
        return [columns]
    keys = []
    for column in columns[:KEY_COLUMNS]:
        if pd.api.types.is_numeric_dtype(table[column]):
            break
        keys.append(column)
    rest = [c for c in columns if c not in keys]
    step = max(1, width - len(keys))
    return [keys + rest[i : i + step] for i in range(0, len(rest), step)]


def _figure_html(number: int, figure: Figure) -> str:
    width, height = Image.open(io.BytesIO(figure.png)).size
    encoded = base64.b64encode(figure.png).decode()
    title = html.escape(figure.title.rstrip("."))
    caption = f" {html.escape(figure.caption)}" if figure.caption else ""
    return (
        f"<figure id='figure-{number}'><img alt='Figure {number}: {title}' width='{width}' "
        f"height='{height}' src='data:image/png;base64,{encoded}'><figcaption><b>Figure "
        f"{number}.</b> <i>{title}.</i>{caption}</figcaption></figure>"
    )


def _table_html(number: int, name: str, table: pd.DataFrame, title: str) -> str:
    formatted = format_table(table)
    numeric = {
        c
        for c in formatted.columns
        if pd.api.types.is_numeric_dtype(table[c]) and not pd.api.types.is_bool_dtype(table[c])
    }

    def cls(column) -> str:
        return " class='num'" if column in numeric else ""

    grids = []
    parts = column_parts(formatted)
    for number_, part in enumerate(parts, start=1):
        head = "".join(
            f"<th{cls(c)} title='{html.escape(str(c))}'>{html.escape(header(str(c)))}</th>"
            for c in part
        )
        body = "".join(
            "<tr>" + "".join(f"<td{cls(c)}>{html.escape(str(v))}</td>" for c, v in row.items())
            + "</tr>"
            for _, row in formatted[part].iterrows()
        )  # fmt: skip
        label = (
            f"<p class='note part'>Part {number_} of {len(parts)}</p>" if len(parts) > 1 else ""
        )
        grids.append(label + _grid(head, body))
    grid = "".join(grids) if len(formatted) else "<p class='note'>(none)</p>"
    if len(formatted) > COLLAPSE_ROWS:
        grid = f"<details><summary>show all {len(formatted)} rows</summary>{grid}</details>"
    files = f"<code>{html.escape(name)}.csv</code>"
    return (
        f"<p class='table-title' id='table-{number}'><b>Table {number}.</b> "
        f"<i>{html.escape(title)}.</i> <span class='note'>({files} holds every digit.)</span>"
        f"</p>{grid}"
    )


def _sessions_html(rows: list[dict]) -> str:
    if not rows:
        return "<p>No session sidecars (.json) were found next to the CSV files.</p>"
    table = pd.DataFrame(rows).astype(str)
    parts = column_parts(table, width=7)
    grids = []
    for number, part in enumerate(parts, start=1):
        head = "".join(f"<th>{html.escape(str(c))}</th>" for c in part)
        body = "".join(
            "<tr>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in row) + "</tr>"
            for row in table[part].itertuples(index=False)
        )
        label = f"<p class='note part'>Part {number} of {len(parts)}</p>" if len(parts) > 1 else ""
        grids.append(label + _grid(head, body))
    grid = "".join(grids)
    if len(table) > COLLAPSE_ROWS:
        grid = f"<details><summary>show all {len(table)} sessions</summary>{grid}</details>"
    return grid


def _html(
    protocol: Protocol,
    dataset: Dataset,
    result: dict,
    methods: str | None,
    origin: dict,
    rows: list[dict],
    stimuli: list[Figure],
    had_set: bool,
) -> str:
    title = protocol.title
    participants = dataset.trials["participant"].nunique()
    blocks = dataset.trials["block"].value_counts()
    training = int(blocks.get("training", 0))
    note = f" ({training} of them training trials, not analysed)" if training else ""
    who = {
        True: "simulated observers",
        "mixed": "participants, some of them simulated observers (see Sessions)",
    }.get(origin.get("simulated"), "participants")
    version = (origin.get("packages") or {}).get("glarelab", "")
    parts = [
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>",
        "<meta name='viewport' content='width=device-width, initial-scale=1'>",
        f"<meta name='generator' content='glarelab {html.escape(str(version))}'>",
        f"<title>{html.escape(title)}: analysis</title><style>{STYLE}</style></head><body>",
        f"<h1>{html.escape(title)}</h1>",
        f"<p class='lead'>Analysis of {participants} {who}, {len(dataset.trials)} trials{note} "
        f"from {len(dataset.files)} session files; study <code>{html.escape(protocol.study)}"
        f"</code> ({html.escape(protocol.paradigm)}).</p>",
        "<nav><a href='#method'>Method</a><a href='#results'>Results</a>"
        "<a href='#tables'>Tables</a><a href='#sessions'>Sessions</a>"
        "<a href='#provenance'>Provenance</a></nav>",
        "<h2 id='method'>Method</h2>",
    ]
    if methods:
        parts.append(f"<p class='results'>{html.escape(methods)}</p>")
    from glarelab.stimuli.stimulus_set import shows_images

    number = 0
    if stimuli:
        parts.append("<h3 id='stimuli'>Stimuli</h3>")
        for figure in stimuli:
            number += 1
            parts.append(_figure_html(number, figure))
    elif (
        not had_set
        and paradigm_analysis(protocol).stimulus_figures is not None
        and shows_images(protocol)  # a questionnaire without a scene has no set to give
    ):
        parts.append(
            "<p class='note'>The stimuli are shown when the report is given the stimulus set "
            "(<code>glarelab analyse … --stimuli SET</code>).</p>"
        )
    if dataset.incomplete_sessions:
        items = "".join(
            f"<li><code>{html.escape(Path(s['file']).name)}</code>: {html.escape(s['status'])}, "
            f"{s['trials']} trials{' (analysed)' if s['trials'] else ' (nothing to analyse)'}"
            "</li>"
            for s in dataset.incomplete_sessions
        )
        parts.append(f"<h3>Sessions that did not complete</h3><ul>{items}</ul>")
    if dataset.excluded:
        items = "".join(
            f"<li>{html.escape(p)}: {html.escape(w)}</li>" for p, w in dataset.excluded.items()
        )
        parts.append(f"<h3>Excluded participants (incomplete design)</h3><ul>{items}</ul>")
    if dataset.pilots:
        items = "".join(
            f"<li><code>{html.escape(Path(s['file']).name)}</code>: participant "
            f"{html.escape(str(s['participant']))}, {s['trials']} trials</li>"
            for s in dataset.pilots
        )
        how = (
            "analysed with the participants' sessions (--include-pilots)"
            if dataset.pilots_included
            else "left out of the analysis (--include-pilots analyses them)"
        )
        parts.append(f"<h3>Pilot sessions, {how}</h3><ul>{items}</ul>")
    unchecked = [
        s for s in dataset.sessions
        if s.get("sidecar") and not s.get("rows_checked", True) and s["file"] in dataset.files
    ]  # fmt: skip
    if unchecked:
        items = "".join(
            f"<li><code>{html.escape(Path(s['file']).name)}</code>: participant "
            f"{html.escape(str(s['participant']))}, {s['trials']} trials</li>"
            for s in unchecked
        )
        parts.append(
            "<h3>Sessions whose rows are not checked</h3><p>Their sidecars are of a data "
            f"format before {ROW_DIGESTS_SINCE}, which records no digest of each row: an edit "
            f"of their rows since the session cannot be seen.</p><ul>{items}</ul>"
        )
    if dataset.flags:
        items = "".join(f"<li>{html.escape(flag)}</li>" for flag in dataset.flags)
        listed = f"<ul>{items}</ul>"
        if len(dataset.flags) > FLAGS_SHOWN:
            listed = f"<details><summary>show all {len(dataset.flags)}</summary>{listed}</details>"
        parts.append(
            "<h3>Trials flagged by the data check (analysed as recorded)</h3><p>"
            f"{len(dataset.flags)} "
            f"{'trials contradict' if len(dataset.flags) > 1 else 'trial contradicts'} the task "
            f"(each says how).</p>{listed}"
        )
    parts.append("<h2 id='results'>Results</h2>")
    paragraphs = result.get("results") or [f"{k}: {v}." for k, v in result["text"].items()]
    parts += [f"<p class='results'>{html.escape(p)}</p>" for p in paragraphs]
    for name, item in result["figures"].items():
        number += 1
        parts.append(_figure_html(number, as_figure(item, name)))
    parts.append("<h2 id='tables'>Tables</h2>")
    wide = (
        ", <code>participants_wide.csv</code> (one row per participant, one column per cell: "
        "the layout of a repeated-measures ANOVA in JASP)"
        if result.get("wide") is not None
        else ""
    )
    parts.append(
        "<p class='note'>Beside each table's CSV: <code>trials.csv</code> (every trial "
        f"analysed){wide}. Every CSV reads into R (<code>read.csv</code>) and JASP as it is: "
        "booleans TRUE/FALSE, numbers in the fewest digits that give back the same value, "
        "missing values empty.</p>"
    )
    captions = result.get("captions", {})
    for index, (name, table) in enumerate(result["tables"].items(), start=1):
        title = captions.get(name, name.replace("_", " "))
        parts.append(_table_html(index, name, table, title))
    parts.append("<h2 id='sessions'>Sessions</h2>")
    parts.append(
        "<p class='note'>One row per session file: its sidecar's record of the run. "
        "✓ marks a hash that matches this analysis's protocol (or stimulus set).</p>"
    )
    parts.append(_sessions_html(rows))
    parts.append("<h2 id='provenance'>Provenance</h2>")
    parts.append(
        "<details><summary>hashes and package versions (provenance.json)</summary><pre>"
        + html.escape(json.dumps(origin, indent=2, default=str))
        + "</pre></details></body></html>"
    )
    return "\n".join(parts)


FORMULA_STARTS = ("=", "+", "@", "\t", "\r")  # a spreadsheet runs such a cell as a formula


def _spreadsheet_safe(table: pd.DataFrame) -> pd.DataFrame:
    """The table with text cells that a spreadsheet would run as a formula (a participant's
    comment "=HYPERLINK(…)") prefixed by an apostrophe, as OWASP advises for CSV export; the
    session CSVs keep the text verbatim."""

    def safe(value):
        if isinstance(value, str) and (
            value.startswith(FORMULA_STARTS) or (value.startswith("-") and not _number(value))
        ):  # "-1+1" and "-2+3+cmd|' /C calc'!A0" are formulas; "-0.5" is a number
            return "'" + value
        return value

    text = table.select_dtypes(include=["object", "string"]).columns
    return table.assign(**{column: table[column].map(safe) for column in text})


def _number(text: str) -> bool:
    """Whether the whole cell reads as a number (a spreadsheet shows it, runs nothing)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def _write_figure(path: Path, figure: Figure) -> None:
    """The figure's PNG, and its PDF and SVG beside it where it was drawn with them."""
    path.write_bytes(figure.png)
    for kind in ("pdf", "svg"):
        vector = getattr(figure.png, kind, None)
        if vector is not None:
            path.with_suffix(f".{kind}").write_bytes(vector)


def _trials(dataset: Dataset) -> pd.DataFrame:
    """Every trial analysed, with its session file's name (``file``) instead of the loader's
    path and line."""
    trials = dataset.trials.drop(columns=["_line"])
    return trials.assign(_file=trials["_file"].map(lambda f: Path(f).name)).rename(
        columns={"_file": "file"}
    )


def write_report(
    protocol: Protocol,
    paths: list[str | Path],
    out: str | Path,
    *,
    exclude_incomplete: bool = False,
    include_aborted: bool = False,
    include_pilots: bool = False,
    include_no_sidecar: bool = False,
    stimuli: str | Path | None = None,
) -> Path:
    """Analyse session CSVs and write the report folder; returns the path of report.html.

    ``protocol`` (a validated protocol) sets the columns, the analysis and the methods
    paragraph naming its parameters; ``stimuli`` (the set's folder) adds its images as the
    display showed them and its manifest hash, and sessions that ran on another set are
    refused. Pilot sessions are left out and listed unless ``include_pilots``.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol.
    paths
        The session CSVs.
    out
        The report's folder, replaced whole; a folder holding other files is refused.
    exclude_incomplete, include_aborted, include_pilots, include_no_sidecar
        As for :func:`glarelab.analysis.load.load_sessions`; default False each.
    stimuli
        The stimulus set's folder; default None: no stimulus figures, sessions not checked
        against a set.

    Returns
    -------
    pathlib.Path
        ``OUT/report.html``.

    Raises
    ------
    glarelab.analysis.dataset.DataError
        For bad input: the data, sessions the analysis cannot vouch for, or a stimulus set
        that fails its manifest or was built from another protocol (nothing is written).
    """
    options = {
        "exclude_incomplete": exclude_incomplete,
        "include_aborted": include_aborted,
        "include_pilots": include_pilots,
        "include_no_sidecar": include_no_sidecar,
        "stimuli": stimuli,
    }
    with output_lock(out, "analysis", what="report"):  # a second analysis into it at once: refused
        return _write_report(protocol, paths, out, **options)


def _write_report(
    protocol: Protocol,
    paths: list[str | Path],
    out: str | Path,
    *,
    exclude_incomplete: bool,
    include_aborted: bool,
    include_pilots: bool,
    include_no_sidecar: bool,
    stimuli: str | Path | None,
) -> Path:
    """:func:`write_report` once ``out`` is held."""
    out = check_replaceable(
        out, kind="report", what="report", inputs=[*paths, *([stimuli] if stimuli else [])]
    )
    stimuli = Path(stimuli) if stimuli is not None else None
    displayed = _displayed(protocol, stimuli)
    dataset, result = analyse(
        protocol,
        paths,
        exclude_incomplete=exclude_incomplete,
        include_aborted=include_aborted,
        include_pilots=include_pilots,
        include_no_sidecar=include_no_sidecar,
        stimuli=stimuli,
    )
    result = result | {"tables": {k: corrected_beside(t) for k, t in result["tables"].items()}}
    live = live_frames(
        dataset.files,
        sidecars=dataset.sidecars,
        scene_live=bool((protocol.data.get("scene") or {}).get("live")),
    )
    if live is not None:  # a live scene: its dropped frames and tracker loss per session
        paragraphs = result.get("results") or [f"{k}: {v}." for k, v in result["text"].items()]
        result = result | {
            "tables": {**result["tables"], "live_frames": live},
            "results": [*paragraphs, live_sentence(live)],
        }
    shown = _stimuli(protocol, result, displayed)
    staging = staging_folder(out)
    try:
        for name, table in result["tables"].items():
            if name in EXPORTS:
                raise ValueError(f"a paradigm's table may not be named {name!r} ({EXPORTS})")
            (staging / f"{name}.csv").write_text(
                csv_text(_spreadsheet_safe(table)), encoding="utf-8"
            )
            (staging / f"{name}.md").write_text(_markdown(table), encoding="utf-8")
        (staging / "trials.csv").write_text(
            csv_text(_spreadsheet_safe(_trials(dataset))), encoding="utf-8"
        )
        if result.get("wide") is not None:
            (staging / "participants_wide.csv").write_text(
                csv_text(_spreadsheet_safe(result["wide"])), encoding="utf-8"
            )
        for name, item in result["figures"].items():
            _write_figure(staging / name, as_figure(item, name))
        for index, figure in enumerate(shown, start=1):
            _write_figure(staging / f"stimulus_{index:02d}.png", figure)
        flags = dataset.trials.groupby("participant")["_file"].first()
        simulated_ids = sum(
            bool(dataset.sidecars.get(file, {}).get("simulated")) for file in flags
        )
        simulated = True if simulated_ids == len(flags) else simulated_ids
        methods = methods_paragraph(protocol, dataset.trials["participant"].nunique(), simulated)
        by_file = dataset.trials.groupby("_file")
        unknown = {  # a CSV without its sidecar: listed, its origin unknown, its rows counted
            file: {
                "status": "no sidecar",
                "participant": rows["participant"].iloc[0],
                "session": int(rows["session"].iloc[0]),
                "trials": len(rows),
                "simulated": None,
            }
            for file, rows in by_file
            if file not in dataset.sidecars
        }
        origin = provenance(unknown | dataset.sidecars, protocol.sha256, stimuli)
        rows = session_rows(
            dataset.files,
            unknown | dataset.sidecars,
            protocol.sha256,
            origin.get("stimulus_set_manifest_sha256"),
        )
        (staging / "provenance.json").write_text(
            json.dumps(origin, indent=2, default=str), encoding="utf-8"
        )
        if methods:
            (staging / "methods.md").write_text(methods + "\n", encoding="utf-8")
        if result.get("results"):
            (staging / "results.md").write_text(
                "\n\n".join(result["results"]) + "\n", encoding="utf-8"
            )
        (staging / REPORT).write_text(
            _html(protocol, dataset, result, methods, origin, rows, shown, stimuli is not None),
            encoding="utf-8",
        )
        replace_folder(staging, out, kind="report")
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return out / REPORT
