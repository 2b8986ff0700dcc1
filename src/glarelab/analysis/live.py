"""What a live scene's frames record says of a session: dropped frames and tracker loss.

A session that showed a scene live (a protocol's ``scene.live``) wrote a row per frame into its
``_frames.tsv`` beside its CSV (:mod:`glarelab.frontend.live`): whether the flip came late
(``dropped``), whether the tracker's sample gave a gaze (``valid_gaze``) and a pupil
(``valid_pupil``), and whether the gaze lay off the scene (``clamped``). :func:`live_frames`
counts them per session; :func:`live_sentence` says it in the report.
"""

from __future__ import annotations

import csv
from pathlib import Path

import pandas as pd

__all__ = ["live_frames", "live_sentence"]


def _frames_path(csv_path: Path) -> Path:
    return csv_path.with_name(csv_path.stem + "_frames.tsv")


def live_frames(files: list[str | Path]) -> pd.DataFrame | None:
    """Per session, the frames of its live scenes: how many, dropped, without gaze or pupil.

    Parameters
    ----------
    files
        The session CSVs; each one's ``STEM_frames.tsv`` is read when it exists.

    Returns
    -------
    pandas.DataFrame or None
        One row per session with live frames (``session``, ``frames``, ``dropped``,
        ``dropped_pct``, ``gaze_lost``, ``gaze_lost_pct``, ``pupil_lost``, ``off_scene``,
        ``render_ms_median``); None when no session showed a live scene.

    Examples
    --------
    >>> live_frames([]) is None
    True
    """
    rows = []
    for file in files:
        path = _frames_path(Path(file))
        if not path.is_file():
            continue
        with path.open(newline="", encoding="utf-8") as handle:
            records = [
                r
                for r in csv.DictReader(handle, delimiter="\t")
                if (r.get("what") or "").endswith(" live") and r.get("valid_gaze") in ("0", "1")
            ]
        if not records:
            continue
        n = len(records)
        dropped = sum(r["dropped"] == "1" for r in records)
        lost = sum(r["valid_gaze"] == "0" for r in records)
        render = pd.to_numeric(pd.Series([r["render_ms"] for r in records]), errors="coerce")
        rows.append(
            {
                "session": Path(file).stem,
                "frames": n,
                "dropped": dropped,
                "dropped_pct": round(100.0 * dropped / n, 2),
                "gaze_lost": lost,
                "gaze_lost_pct": round(100.0 * lost / n, 2),
                "pupil_lost": sum(r["valid_pupil"] == "0" for r in records),
                "off_scene": sum(r["clamped"] == "1" for r in records),
                "render_ms_median": round(float(render.median()), 3),
            }
        )
    return pd.DataFrame(rows) if rows else None


def live_sentence(table: pd.DataFrame) -> str:
    """The report's sentence on the live frames.

    Parameters
    ----------
    table
        :func:`live_frames`'s table.

    Returns
    -------
    str

    Examples
    --------
    >>> import textwrap
    >>> t = pd.DataFrame([{"session": "a", "frames": 200, "dropped": 2, "dropped_pct": 1.0,
    ...     "gaze_lost": 10, "gaze_lost_pct": 5.0, "pupil_lost": 10, "off_scene": 0,
    ...     "render_ms_median": 8.0}])
    >>> print(textwrap.fill(live_sentence(t), 80))
    The live scene was shown in 200 frames over 1 session: 2 dropped (1.0 %; at most
    1.0 % in a session), and 10 without a gaze from the tracker (5.0 %; at most 5.0 %
    in a session), their last gaze held.
    """
    frames = int(table["frames"].sum())
    dropped = int(table["dropped"].sum())
    lost = int(table["gaze_lost"].sum())
    sessions = len(table)
    return (
        f"The live scene was shown in {frames} frames over {sessions} "
        f"session{'s' if sessions != 1 else ''}: {dropped} dropped "
        f"({100 * dropped / frames:.1f} %; at most {table['dropped_pct'].max():.1f} % in a "
        f"session), and {lost} without a gaze from the tracker ({100 * lost / frames:.1f} %; "
        f"at most {table['gaze_lost_pct'].max():.1f} % in a session), their last gaze held."
    )
