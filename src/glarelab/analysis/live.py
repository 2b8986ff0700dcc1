"""What a live scene's frames record says of a session: dropped frames and tracker loss.

A session that showed a scene live (a protocol's ``scene.live``) wrote a row per frame into its
``_frames.tsv`` beside its CSV (:mod:`glarelab.frontend.live`): whether the flip came late
(``dropped``), whether the tracker's sample gave a gaze (``valid_gaze``) and a pupil
(``valid_pupil``), and whether the gaze lay off the scene (``clamped``). :func:`live_frames`
counts them per session; :func:`live_sentence` says it in the report.
"""

from __future__ import annotations

import csv
import errno
import json
import math
import re
from pathlib import Path

import pandas as pd

from glarelab.files.inputs import loads_json

__all__ = ["live_frames", "live_sentence"]


def _frames_path(csv_path: Path) -> Path:
    return csv_path.with_name(csv_path.stem + "_frames.tsv")


# the header glarelab.frontend.live writes (its FRAME_COLUMNS after what, frame, interval_ms)
LIVE_HEADER = (
    "what", "frame", "interval_ms", "time_s", "tracker_time_s", "gaze_x_px", "gaze_y_px",
    "pupil_mm", "target_cd_m2", "adaptation_cd_m2", "render_ms", "dropped", "valid_gaze",
    "valid_pupil", "clamped", "new_bank_entries",
)  # fmt: skip
# the pupils a live frame is rendered for: the tracker's clamped to Luidolt's 2-8 mm
# (§5.2.1 ii; glarelab.glare.night.live's bank), so a frame record holds no other
PUPIL_RANGE_MM = (2.0, 8.0)
_LIVE_WHAT = re.compile(r"trial [1-9][0-9]* live")
_FOREIGN_LIVE = re.compile(r"trial [1-9][0-9]* live[^\t]")
_FLAGS = ("dropped", "valid_gaze", "valid_pupil", "clamped")
_TIMES = ("time_s", "tracker_time_s", "render_ms", "target_cd_m2", "adaptation_cd_m2")


def _live_records(path: Path) -> list[dict]:
    """The live rows of a frame record, each checked: a row the session could not have
    written (a value out of its range, a field too many or too few, a frame missing,
    repeated or out of order, a cut last line) is refused with its file, line and column."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise ValueError(f"{path}: not a frame record (not UTF-8 text: {error.reason})") from None
    lines = text.splitlines()
    if not lines:
        raise ValueError(f"{path}: empty; a frame record begins with its header line")
    live = [
        (number, fields)
        for number, fields in enumerate(csv.reader(lines, delimiter="\t"), start=1)
        if fields and fields[0].endswith(" live")
    ]
    if not live:
        foreign = next(
            (n for n, line in enumerate(lines, start=1) if _FOREIGN_LIVE.match(line)), None
        )
        if foreign is not None:  # a spreadsheet saved it with another separator
            raise ValueError(
                f"{path}, line {foreign}: a live frame row not separated by tabs; a frame "
                "record is tab-separated"
            )
        return []
    header = tuple(next(csv.reader(lines[:1], delimiter="\t")))
    if header != LIVE_HEADER:
        raise ValueError(
            f"{path}, line 1: the header is not a live frame record's ({', '.join(LIVE_HEADER)})"
        )
    if not text.endswith("\n"):
        raise ValueError(f"{path}, line {len(lines)}: the last line is cut (no line end)")
    records = []
    previous: tuple[str, int, int] | None = None  # what, frame, run
    runs = [n for n, line in enumerate(lines, start=1) if line.startswith("run ")]
    for number, fields in live:
        where = f"{path}, line {number}"
        if not _LIVE_WHAT.fullmatch(fields[0]):
            raise ValueError(f"{where}, column what: {fields[0]!r} is not 'trial N live'")
        if len(fields) != len(LIVE_HEADER):
            raise ValueError(f"{where}: {len(fields)} fields, the header has {len(LIVE_HEADER)}")
        record = dict(zip(LIVE_HEADER, fields, strict=True))
        for column in _FLAGS:
            if record[column] not in ("0", "1"):
                raise ValueError(f"{where}, column {column}: {record[column]!r} is not 0 or 1")
        for column in ("frame", "new_bank_entries"):
            if not record[column].isdigit():
                raise ValueError(
                    f"{where}, column {column}: {record[column]!r} is not a whole number >= 0"
                )
        numbers = {
            c: record[c] for c in (*_TIMES, "gaze_x_px", "gaze_y_px", "pupil_mm", "interval_ms")
        }
        for column, value in numbers.items():
            if column == "interval_ms" and record["frame"] == "0" and value == "":
                continue  # the first frame has no flip before it
            try:
                x = float(value)
            except ValueError:
                raise ValueError(f"{where}, column {column}: {value!r} is not a number") from None
            low = 0.0 if column in (*_TIMES, "interval_ms") else -math.inf
            if (
                not math.isfinite(x)
                or x < low
                or (column in ("pupil_mm", "interval_ms") and x <= 0)
                or (column == "pupil_mm" and not PUPIL_RANGE_MM[0] <= x <= PUPIL_RANGE_MM[1])
            ):
                allowed = (
                    f"in [{PUPIL_RANGE_MM[0]:g}, {PUPIL_RANGE_MM[1]:g}] mm"
                    if column == "pupil_mm"
                    else "> 0"
                    if column == "interval_ms"
                    else (">= 0" if low == 0.0 else "finite")
                )
                raise ValueError(
                    f"{where}, column {column}: {value!r}; allowed: a number {allowed}"
                )
        run = sum(r < number for r in runs)
        frame = int(record["frame"])
        expected = (
            previous[1] + 1 if previous is not None and previous[::2] == (fields[0], run) else 0
        )
        if frame != expected:
            raise ValueError(
                f"{where}, column frame: frame {frame} of {fields[0]} where frame {expected} "
                "was due (a frame missing, repeated or out of order)"
            )
        if frame == 0 and any(r["what"] == fields[0] and r["_run"] == run for r in records):
            raise ValueError(f"{where}: {fields[0]} begins a second time in run {run}")
        previous = (fields[0], frame, run)
        records.append(record | {"_run": run})
    return records


_RUN_LINE = re.compile(r"run (\d+) started [^;]*; log time 0 = Unix time ([0-9.]+) s(; PILOT)?")


def _runs_of_this_session(path: Path, csv_path: Path) -> None:
    """The frame record's runs are its session's: each run line's clock epoch is the one the
    sidecar's run recorded, no run more than the sidecar's, and a pilot's runs only in a
    pilot's file (a ``_pilot`` stem), a participant's only in a participant's."""
    pilot = csv_path.stem.endswith("_pilot")
    sidecar_path = csv_path.with_suffix(".json")
    try:
        sidecar = loads_json(sidecar_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        sidecar = None  # no sidecar (--include-no-sidecar) or one the loader judged already
    runs = sidecar.get("runs") if isinstance(sidecar, dict) else None
    lines = path.read_text(encoding="utf-8").splitlines()
    for number, line in enumerate(lines, start=1):
        match = _RUN_LINE.match(line)
        if match is None:
            continue
        run, epoch = int(match[1]), float(match[2])
        if bool(match[3]) != pilot:
            raise ValueError(
                f"{path}, line {number}: run {run} is {'a pilot' if match[3] else 'a session'}'s"
                f" but the session {csv_path.name} is {'a pilot' if pilot else 'not a pilot'}: "
                "the frame record of another session?"
            )
        if not isinstance(runs, list):
            continue
        recorded = runs[run - 1] if 1 <= run <= len(runs) else None
        clock = recorded.get("clock_epoch_s") if isinstance(recorded, dict) else None
        if recorded is None or (
            isinstance(clock, int | float) and abs(clock - epoch) > RUN_EPOCH_TOLERANCE_S
        ):
            raise ValueError(
                f"{path}, line {number}: run {run} began at Unix time {epoch:.3f} s, but "
                f"{sidecar_path.name} "
                + (
                    f"records {len(runs)} run(s)"
                    if recorded is None
                    else f"records its run {run} at {clock:.3f} s"
                )
                + ": the frame record of another session?"
            )


def _dropped_as_in_the_csv(path: Path, csv_path: Path, records: list[dict]) -> None:
    """The CSV's ``dropped_frames`` of a trial that showed a live scene is the count of its
    frames flagged dropped in the record (:meth:`LiveView.run`'s count; the last run's, when a
    resumed session showed the trial again)."""
    last: dict[int, tuple[int, int]] = {}  # trial: (run, dropped)
    for record in records:
        trial = int(record["what"].split()[1])
        run, dropped = last.get(trial, (record["_run"], 0))
        if record["_run"] != run:
            run, dropped = record["_run"], 0
        last[trial] = (run, dropped + (record["dropped"] == "1"))
    try:
        with csv_path.open(encoding="utf-8", newline="") as handle:
            rows = list(csv.DictReader(handle))
    except (OSError, UnicodeDecodeError, csv.Error):
        return  # the loader judged the CSV already
    for line, row in enumerate(rows, start=2):
        try:
            trial, written = int(row.get("trial") or ""), int(row.get("dropped_frames") or "")
        except ValueError:
            continue
        if trial in last and row.get("offset_s") and written != last[trial][1]:
            raise ValueError(
                f"{csv_path}, line {line}, column dropped_frames: {written}, but its frame "
                f"record {path.name} flags {last[trial][1]} of trial {trial}'s live frames "
                "dropped (one of them edited, or the record of another session?)"
            )


RUN_EPOCH_TOLERANCE_S = 0.002  # the run line writes the epoch to 1 ms


def _showed_live(sidecar: dict, scene_live: bool) -> bool:
    """Whether the session of this sidecar showed its protocol's live scene: a session on a
    screen (``simulated: false``) of a protocol with ``scene.live``; a simulated observer
    answers without a screen and writes no frame record (its runs' ``frame_intervals`` null)."""
    return scene_live and sidecar.get("simulated") is False


def live_frames(
    files: list[str | Path],
    *,
    sidecars: dict[str, dict] | None = None,
    scene_live: bool = False,
) -> pd.DataFrame | None:
    """Per session, the frames of its live scenes: how many, dropped, without gaze or pupil.

    Parameters
    ----------
    files
        The session CSVs; each one's ``STEM_frames.tsv`` is read when it exists.
    sidecars
        The sessions' sidecars by CSV path (:class:`glarelab.analysis.dataset.Dataset`'s);
        default None: none known. A session with a sidecar is held to what it says: one
        that showed a live scene (``simulated: false`` and ``scene_live``) must have a frame
        record with live rows, one that did not may have none.
    scene_live
        Whether the protocol's scene is live (``scene.live``); default False.

    Returns
    -------
    pandas.DataFrame or None
        One row per session with live frames (``session``, ``frames``, ``dropped``,
        ``dropped_pct``, ``gaze_lost``, ``gaze_lost_pct``, ``pupil_lost``, ``off_scene``,
        ``render_ms_median``); None when no session showed a live scene.

    Raises
    ------
    ValueError
        For a frame record the session could not have written, naming its file, line and
        column: a live row with a value out of its range or a field too many or too few, a
        frame missing, repeated or out of order, a cut last line, a header that is not the
        record's, an empty file; a live session whose frame record is missing or holds no
        live rows; live rows in the record of a session that showed no live scene.

    Examples
    --------
    >>> live_frames([]) is None
    True
    """
    rows = []
    for file in files:
        path = _frames_path(Path(file))
        sidecar = (sidecars or {}).get(str(file))
        live = None if sidecar is None else _showed_live(sidecar, scene_live)
        try:
            exists, is_file = path.exists(), path.is_file()
        except OSError as error:  # the CSV's name is too long for a longer one beside it
            if error.errno != errno.ENAMETOOLONG:
                raise
            exists = is_file = False  # no session could have written it
        if exists and not is_file:
            raise ValueError(f"{path}: not a file; a session's frame record is a text file")
        if not is_file:
            if live:
                raise ValueError(
                    f"{path}: missing; the session showed a live scene (its sidecar: simulated "
                    "false; the protocol: scene.live) and wrote its frames there"
                )
            continue
        named = (
            {
                run.get("frame_intervals")
                for run in sidecar.get("runs") or []
                if isinstance(run, dict)
            }
            if live
            else set()
        )
        if named - {path.name}:
            raise ValueError(
                f"{Path(file).with_suffix('.json')}: its runs' frame_intervals name "
                f"{', '.join(sorted(map(json.dumps, named - {path.name})))}, but a live "
                f"session's runs write its frames to {path.name} (the sidecar edited?)"
            )
        records = _live_records(path)
        if live and not records:
            raise ValueError(
                f"{path}: no live frame rows ('trial N live'); the session showed a live scene "
                "(its sidecar: simulated false; the protocol: scene.live) and wrote a row per "
                "frame (the record cut or of another session?)"
            )
        if live is False and records:
            why = (
                "it is a simulated observer's (its sidecar: simulated true)"
                if sidecar.get("simulated")
                else "the protocol's scene is not live"
            )
            raise ValueError(
                f"{path}: live frame rows, but the session showed no live scene: {why}; the "
                "frame record of another session?"
            )
        if not records:
            continue
        _runs_of_this_session(path, Path(file))
        _dropped_as_in_the_csv(path, Path(file), records)
        n = len(records)
        dropped = sum(r["dropped"] == "1" for r in records)
        lost = sum(r["valid_gaze"] == "0" for r in records)
        render = pd.Series([float(r["render_ms"]) for r in records])
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
