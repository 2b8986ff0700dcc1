"""Writing an analysis: tables (CSV and Markdown), figures (PNG) and one self-contained HTML.

Everything is written to a staging folder next to the destination and moved into place only
when all of it succeeded, so a failing analysis leaves no partial report behind; an earlier
report in the destination is replaced whole, and a folder holding anything else is refused
(:mod:`protocols.folders`).
"""

from __future__ import annotations

import base64
import html
import json
import shutil
from pathlib import Path

import pandas as pd

from protocols.folders import check_replaceable, replace_folder, staging_folder

from .load import Dataset, load_sessions
from .methods import provenance
from .paradigms import PARADIGMS

__all__ = ["analyse", "methods_paragraph", "write_report"]

REPORT = "report.html"


def _markdown(table: pd.DataFrame) -> str:
    formatted = table.copy()
    for column in formatted.columns:
        if pd.api.types.is_float_dtype(formatted[column]):
            formatted[column] = formatted[column].map(lambda v: "" if pd.isna(v) else f"{v:.4g}")
    header = "| " + " | ".join(map(str, formatted.columns)) + " |"
    rule = "| " + " | ".join("---" for _ in formatted.columns) + " |"
    rows = ["| " + " | ".join(map(str, row)) + " |" for row in formatted.itertuples(index=False)]
    return "\n".join([header, rule, *rows]) + "\n"


def analyse(
    protocol,
    paths: list[str | Path],
    *,
    exclude_incomplete: bool = False,
    include_aborted: bool = False,
) -> tuple[Dataset, dict]:
    """Load the sessions of the protocol's study and run its paradigm's analysis."""
    dataset = load_sessions(
        protocol, paths, exclude_incomplete=exclude_incomplete, include_aborted=include_aborted
    )
    return dataset, PARADIGMS[protocol.paradigm].analyse(dataset, protocol)


def methods_paragraph(protocol, participants: int, simulated: bool | int) -> str:
    """Methods text naming the protocol's actual parameters; ``simulated`` is true when every
    participant was a simulated observer, or the number of them among the participants."""
    if simulated is True:
        who = f"{participants} simulated observers"
    elif not simulated:
        who = f"{participants} participants"
    else:
        who = f"{participants} participants ({simulated} of them simulated observers)"
    return PARADIGMS[protocol.paradigm].methods(protocol, participants, who)


def _html(title: str, dataset: Dataset, result: dict, methods: str | None, origin: dict) -> str:
    parts = [
        "<!doctype html><html><head><meta charset='utf-8'>",
        f"<title>{html.escape(title)}</title>",
        "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;line-height:1.4}"
        "table{border-collapse:collapse;font-size:0.85em;margin:0.5em 0 1.5em}"
        "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}"
        "th{background:#f2f2f2}code{background:#f5f5f5}</style></head><body>",
        f"<h1>{html.escape(title)}: analysis</h1>",
    ]
    participants = dataset.trials["participant"].nunique()
    blocks = dataset.trials["block"].value_counts()
    training = int(blocks.get("training", 0))
    note = f" ({training} of them training trials, not analysed)" if training else ""
    parts.append(
        f"<p>{participants} participants, {len(dataset.trials)} trials{note} from "
        f"{len(dataset.files)} session files.</p>"
    )
    if methods:
        parts.append(f"<h2>Methods</h2><p>{html.escape(methods)}</p>")
    if dataset.incomplete_sessions:
        items = "".join(
            f"<li><code>{html.escape(Path(s['file']).name)}</code>: {html.escape(s['status'])}, "
            f"{s['trials']} trials{' (analysed)' if s['trials'] else ' (nothing to analyse)'}"
            "</li>"
            for s in dataset.incomplete_sessions
        )
        parts.append(f"<h2>Sessions that did not complete</h2><ul>{items}</ul>")
    if dataset.excluded:
        items = "".join(
            f"<li>{html.escape(p)}: {html.escape(w)}</li>" for p, w in dataset.excluded.items()
        )
        parts.append(f"<h2>Excluded participants (incomplete design)</h2><ul>{items}</ul>")
    if result["text"]:
        items = "".join(
            f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>"
            for k, v in result["text"].items()
        )
        parts.append(f"<h2>Results</h2><ul>{items}</ul>")
    for name, data in result["figures"].items():
        encoded = base64.b64encode(data).decode()
        parts.append(
            f"<h2>{html.escape(name)}</h2><img alt='{html.escape(name)}' "
            f"src='data:image/png;base64,{encoded}' style='max-width:100%'>"
        )
    for name, table in result["tables"].items():
        parts.append(f"<h2>{html.escape(name.replace('_', ' '))}</h2>")
        parts.append(table.to_html(index=False, float_format=lambda v: f"{v:.4g}", na_rep=""))
    files = "".join(f"<li><code>{html.escape(Path(f).name)}</code></li>" for f in dataset.files)
    parts.append(f"<h2>Data</h2><ul>{files}</ul>")
    parts.append(
        "<h2>Provenance</h2><pre>"
        + html.escape(json.dumps(origin, indent=2, default=str))
        + "</pre></body></html>"
    )
    return "\n".join(parts)


def write_report(
    protocol,
    paths: list[str | Path],
    out: str | Path,
    *,
    exclude_incomplete: bool = False,
    include_aborted: bool = False,
    stimuli: str | Path | None = None,
) -> Path:
    """Analyse session CSVs and write the report folder; returns the path of report.html.

    ``protocol`` (a validated protocol) sets the columns, the analysis and the methods
    paragraph naming its parameters; ``stimuli`` (the set's folder) adds its manifest hash.

    Raises
    ------
    analysis.load.DataError
        For bad input (nothing is written).
    """
    out = check_replaceable(out, marker=REPORT, what="report")
    dataset, result = analyse(
        protocol, paths, exclude_incomplete=exclude_incomplete, include_aborted=include_aborted
    )
    staging = staging_folder(out)
    try:
        for name, table in result["tables"].items():
            table.to_csv(staging / f"{name}.csv", index=False)
            (staging / f"{name}.md").write_text(_markdown(table))
        for name, data in result["figures"].items():
            (staging / name).write_bytes(data)
        flags = dataset.trials.groupby("participant")["_file"].first()
        simulated_ids = sum(
            bool(dataset.sidecars.get(file, {}).get("simulated")) for file in flags
        )
        simulated = True if simulated_ids == len(flags) else simulated_ids
        methods = methods_paragraph(protocol, dataset.trials["participant"].nunique(), simulated)
        origin = provenance(dataset.sidecars, protocol.sha256, Path(stimuli) if stimuli else None)
        (staging / "provenance.json").write_text(json.dumps(origin, indent=2, default=str))
        if methods:
            (staging / "methods.md").write_text(methods + "\n")
        (staging / REPORT).write_text(
            _html(protocol.title, dataset, result, methods, origin), encoding="utf-8"
        )
        replace_folder(staging, out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return out / REPORT
