"""Writing an analysis: tables (CSV and Markdown), figures (PNG) and one self-contained HTML.

Everything is written to a temporary folder next to the destination and moved into place only
when all of it succeeded, so a failing analysis leaves no partial report behind.
"""

from __future__ import annotations

import base64
import html
import json
import os
import shutil
import tempfile
from pathlib import Path

import pandas as pd

from .load import Dataset, load_sessions
from .methods import provenance
from .paradigms import PARADIGMS

__all__ = ["analyse", "methods_paragraph", "write_report"]


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
    protocol, paths: list[str | Path], *, exclude_incomplete: bool = False
) -> tuple[Dataset, dict]:
    """Load the sessions of the protocol's study and run its paradigm's analysis."""
    dataset = load_sessions(protocol, paths, exclude_incomplete=exclude_incomplete)
    return dataset, PARADIGMS[protocol.paradigm].analyse(dataset, protocol)


def methods_paragraph(protocol, participants: int, simulated: bool) -> str:
    """Methods text naming the protocol's actual parameters."""
    who = f"{participants} {'simulated observers' if simulated else 'participants'}"
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
    out = Path(out)
    dataset, result = analyse(protocol, paths, exclude_incomplete=exclude_incomplete)
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=".report-", dir=out.parent))
    try:
        for name, table in result["tables"].items():
            table.to_csv(staging / f"{name}.csv", index=False)
            (staging / f"{name}.md").write_text(_markdown(table))
        for name, data in result["figures"].items():
            (staging / name).write_bytes(data)
        simulated = any(s.get("simulated") for s in dataset.sidecars.values())
        methods = methods_paragraph(protocol, dataset.trials["participant"].nunique(), simulated)
        origin = provenance(dataset.sidecars, protocol.sha256, Path(stimuli) if stimuli else None)
        (staging / "provenance.json").write_text(json.dumps(origin, indent=2, default=str))
        if methods:
            (staging / "methods.md").write_text(methods + "\n")
        (staging / "report.html").write_text(
            _html(protocol.title, dataset, result, methods, origin), encoding="utf-8"
        )
        out.mkdir(parents=True, exist_ok=True)
        for item in staging.iterdir():
            os.replace(item, out / item.name)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return out / "report.html"
