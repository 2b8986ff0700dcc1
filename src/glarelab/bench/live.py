"""``glarelab bench --live``: night vision per frame against the offline ``render_night``.

:class:`glarelab.glare.night.live.LiveNight` renders adaptation and glare for a gaze and a pupil
that change every frame, and with them (the ``'full'`` pipeline) the acuity loss and the
scotopic colour. Here it runs a scripted gaze (a sweep over the street and back, 60 frames at
60 Hz) with a pupil moving between 3 and 6 mm: a first pass fills its bank (each adaptation
threshold and pupil the path visits, ``build_s``), then ``repeats`` passes are timed frame by
frame, each frame with its display codes as a session shows it (``render_ms`` median, 95th and
99th percentile, frames per second from the median, frames over the 16.7 ms of 60 Hz,
``over_budget_frames``; the process's CPU time per frame, ``cpu_ms``, which a busy machine
does not inflate as it does the wall time; the encoding alone, timed again on the finished
frame, ``encode_ms``; frames that had to add to the bank, ``late_frames``). The machine's load (the
1-minute average of runnable processes, 2 cores) is recorded before and after. On frames
of the same path :func:`glarelab.glare.render_night` renders the same gaze, pupil and
previous adaptation with the same effects, once exact (``tolerance_codes=0``) and once as the
offline study runs it (0.5 codes), timed; the error is the largest difference in display codes
(continuous codes of the night study's display, 10-bit, 200 cd/m², gamma 2.2: 0.5 is half a
step).

Workloads: the night street of the night study (3 lamps of 1e4 cd/m², ambient 0.05 cd/m², its
0.0297° pixel) at 640 × 400 and 1280 × 720.
"""

from __future__ import annotations

import csv
import math
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from glarelab import glare
from glarelab.display.calibration import synthetic_calibration
from glarelab.files.atomic import atomic_open, write_text
from glarelab.glare.models.eye import regime
from glarelab.glare.night.live import LiveNight
from glarelab.glare.night.pipeline import eye_state_model
from glarelab.glare.rendering.display import CodeTable, display_codes
from glarelab.stimuli.night import night_street

__all__ = [
    "LIVE_WORKLOADS",
    "PIPELINES",
    "live_bench",
    "live_table",
    "over_budget",
    "write_live_bench",
]

LIVE_WORKLOADS = {"street_640x400": (640, 400), "street_1280x720": (1280, 720)}
PIXEL_DEG = 0.0297  # the night study's display (27 in, 1920 × 1080 at 0.6 m)
DISPLAY_MAX_CD_M2 = 200.0  # night2026.toml's display
ADAPTED_DISPLAY_CD_M2 = 3.0  # and its key
FRAME_S = 1 / 60


def _path(size: tuple[int, int], frames: int) -> list[tuple[tuple[float, float], float]]:
    """A gaze sweeping from the top-left corner to the bottom-right and back, and a pupil
    between 3 and 6 mm: ``((row, column), pupil_mm)`` per frame."""
    width, height = size
    path = []
    for i in range(frames):
        phase = 1.0 - abs(1.0 - 2.0 * i / max(frames - 1, 1))  # 0 → 1 → 0
        gaze = (phase * (height - 1), phase * (width - 1))
        path.append((gaze, round(4.5 + 1.5 * math.sin(2 * math.pi * i / frames), 6)))
    return path


PIPELINES = {
    "glare": ("adaptation", "glare"),  # glare + adaptation
    "full": ("adaptation", "glare", "acuity", "scotopic"),  # Luidolt's four effects
}


def live_bench(
    *,
    frames: int = 60,
    compared: int = 3,
    repeats: int = 3,
    only: tuple[str, ...] | None = None,
    workloads: dict[str, tuple[int, int]] | None = None,
    pipelines: tuple[str, ...] = tuple(PIPELINES),
    log: Callable[[str], None] = print,
) -> list[dict]:
    """Time the per-frame renderer on each workload and measure it against ``render_night``.

    Parameters
    ----------
    frames
        Frames of the scripted path, >= 2; default 60 (one second at 60 Hz).
    compared
        Frames of the path rendered offline too (spread over it), >= 1; default 3.
    repeats
        Timed passes over the path, >= 1; default 3 (180 frames).
    only
        Workload names of :data:`LIVE_WORKLOADS` to run; default None: all.
    workloads
        Other workloads, ``name → (width, height)`` of the street; default None:
        :data:`LIVE_WORKLOADS`.
    pipelines
        Names of :data:`PIPELINES`: ``'glare'`` (adaptation and glare) and ``'full'`` (also
        the acuity loss and the scotopic colour); default both.
    log
        Called with a line per workload; default :func:`print`.

    Returns
    -------
    list of dict
        One row per workload and pipeline: ``render_ms_median``, ``render_ms_p95``,
        ``render_ms_p99`` (each frame with its codes), ``over_budget_frames`` (over 1/60 s),
        ``fps`` (1000 / median), ``cpu_ms_median``, ``encode_ms_median``, ``late_frames``,
        ``exact_px_median`` (pixels blurred directly), ``build_s`` (filling the bank),
        ``bank_entries``, ``offline_ms`` and ``offline_exact_ms`` (``render_night`` per
        frame), ``max_codes`` (against the offline study's ``render_night``) and
        ``max_codes_exact`` (against the exact one), ``load_before`` and ``load_after``.

    Raises
    ------
    ValueError
        For too few frames, compared frames or repeats, or an unknown pipeline.
    """
    if frames < 2 or compared < 1 or repeats < 1:
        raise ValueError(
            f"frames must be >= 2, compared and repeats >= 1; got {frames}, {compared}, {repeats}"
        )
    for name in pipelines:
        if name not in PIPELINES:
            raise ValueError(f"pipelines must be of {tuple(PIPELINES)}; got {name!r}")
    lut = synthetic_calibration(max_cd_m2=DISPLAY_MAX_CD_M2, black_cd_m2=0.05, bit_depth=10).lut
    rows = []
    for name, size in (LIVE_WORKLOADS if workloads is None else workloads).items():
        if only is not None and name not in only:
            continue
        scene = night_street(
            size, pixel_deg=PIXEL_DEG, lamps=3, lamp_cd_m2=1e4, ambient_cd_m2=0.05,
            rng=np.random.default_rng(0),
        )["img"]  # fmt: skip
        for pipeline in pipelines:
            log(f"live {name} ({pipeline}): {size[0]} × {size[1]} px at {PIXEL_DEG:g}°")
            rows.append(
                _bench_one(name, size, scene, pipeline, frames, compared, repeats, lut, log)
            )
    return rows


def over_budget(render_ms: list[float], frame_s: float) -> int:
    """Frames whose time exceeds the refresh period: each would miss its refresh.

    Parameters
    ----------
    render_ms
        Each frame's time with its codes, ms.
    frame_s
        The refresh period, s, > 0.

    Returns
    -------
    int
        How many frames took longer than ``frame_s``.

    Examples
    --------
    >>> over_budget([10.0, 16.6, 16.7, 30.0], 1 / 60)  # 1/60 s is 16.667 ms
    2
    """
    return int(np.sum(np.asarray(render_ms, dtype=float) > 1e3 * frame_s))


def _bench_one(name, size, scene, pipeline, frames, compared, repeats, lut, log) -> dict:
    effects = PIPELINES[pipeline]
    full = "acuity" in effects
    options = {"display_max_cd_m2": DISPLAY_MAX_CD_M2}
    load_before = os.getloadavg()[0]
    live = LiveNight(
        scene, pixel_deg=PIXEL_DEG, adapted_display_cd_m2=ADAPTED_DISPLAY_CD_M2, acuity=full,
        scotopic=full, **options,
    )  # fmt: skip
    path = _path(size, frames)
    prepared = live.prepare()  # as a session does before its first frame
    build_s, entries = prepared.seconds, prepared.entries
    compare_at = set(np.linspace(0, frames - 1, compared).astype(int))
    times, cpu, exact, late, states, shown, encode = [], [], [], 0, [], {}, []
    table = CodeTable(lut)  # the codes the session shows each frame (frontend.live.LiveView)
    previous = live.frame(
        gaze_px=path[0][0], pupil_mm=path[0][1], frame_time_s=FRAME_S, encode=table
    )
    for repeat in range(repeats):
        for index, (gaze, pupil) in enumerate(path):
            before = previous.adaptation_cd_m2
            start, start_cpu = time.perf_counter(), time.process_time()
            frame = live.frame(gaze_px=gaze, pupil_mm=pupil, frame_time_s=FRAME_S, encode=table)
            times.append(1e3 * (time.perf_counter() - start))
            cpu.append(1e3 * (time.process_time() - start_cpu))
            start = time.perf_counter()  # the encoding alone, once more (not in the frame's time)
            table(frame.image)
            encode.append(1e3 * (time.perf_counter() - start))
            exact.append(frame.exact_px)
            late += frame.new_entries > 0
            if repeat == 0 and index in compare_at:
                shown[index] = frame.image.copy()
                states.append((index, before, frame))
            previous = frame
    load_after = os.getloadavg()[0]
    errors = {"": [], "_exact": []}
    offline = {"": [], "_exact": []}
    for index, before, frame in states:
        for suffix, tolerance in (("", 0.5), ("_exact", 0.0)):
            start = time.perf_counter()
            reference = glare.render_night(
                scene, pixel_deg=PIXEL_DEG, effects=effects,
                glare_model=eye_state_model(  # the frame's pupil and regime (of its L_i)
                    glare.VosGlare(), pupil_mm=frame.pupil_mm,
                    regime=regime(frame.adaptation_cd_m2),
                ),
                pupil_from_adaptation=False, gaze_px=frame.gaze_px, frame_time_s=FRAME_S,
                initial_adaptation_cd_m2=before, tolerance_codes=tolerance,
                adapted_display_cd_m2=ADAPTED_DISPLAY_CD_M2, **options,
            )  # fmt: skip
            offline[suffix].append(1e3 * (time.perf_counter() - start))
            error = np.abs(display_codes(shown[index], lut) - display_codes(reference.frames, lut))
            errors[suffix].append(float(error.max()))
    median = float(np.median(times))
    row = {
        "workload": name,
        "pipeline": pipeline,
        "width": size[0],
        "height": size[1],
        "frames": len(times),
        "render_ms_median": median,
        "render_ms_p95": float(np.quantile(times, 0.95)),
        "render_ms_p99": float(np.quantile(times, 0.99)),
        "over_budget_frames": over_budget(times, FRAME_S),
        "fps": 1e3 / median,
        "cpu_ms_median": float(np.median(cpu)),
        "encode_ms_median": float(np.median(encode)),
        "late_frames": int(late),
        "exact_px_median": float(np.median(exact)),
        "build_s": build_s,
        "bank_entries": entries,
        "offline_ms": float(np.median(offline[""])),
        "offline_exact_ms": float(np.median(offline["_exact"])),
        "max_codes": max(errors[""]),
        "max_codes_exact": max(errors["_exact"]),
        "load_before": load_before,
        "load_after": load_after,
    }
    log(
        f"    {median:.2f} ms/frame median ({row['fps']:.0f} fps), p99 "
        f"{row['render_ms_p99']:.2f} ms, {row['over_budget_frames']} of {len(times)} over "
        f"{1e3 * FRAME_S:.1f} ms, CPU {row['cpu_ms_median']:.2f} ms, codes "
        f"{row['encode_ms_median']:.2f} ms; bank {entries} "
        f"entries in {build_s:.1f} s; render_night {row['offline_ms']:.0f} ms; error "
        f"{row['max_codes']:.4f} codes ({row['max_codes_exact']:.4f} against the exact "
        f"render); load {load_before:.1f} → {load_after:.1f}"
    )
    return row


def live_table(rows: list[dict]) -> str:
    """The rows as a Markdown table.

    Parameters
    ----------
    rows
        The rows of :func:`live_bench`.

    Returns
    -------
    str
        The table, one line per row, ending in a new line.
    """
    lines = [
        "| workload | pipeline | ms/frame (median) | ms/frame (99 %) | frames over 1/60 s "
        "| fps | CPU ms/frame | codes ms/frame | bank (entries, s) "
        "| render_night ms/frame (0.5 codes, exact) "
        "| max error, codes (vs 0.5-code, vs exact) | load (before, after) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        lines.append(
            f"| {r['workload']} | {r['pipeline']} | {r['render_ms_median']:.2f} | "
            f"{r['render_ms_p99']:.2f} | {r['over_budget_frames']} of {r['frames']} | "
            f"{r['fps']:.0f} | {r['cpu_ms_median']:.2f} | "
            f"{r['encode_ms_median']:.2f} | "
            f"{r['bank_entries']}, {r['build_s']:.1f} | "
            f"{r['offline_ms']:.0f}, {r['offline_exact_ms']:.0f} | "
            f"{r['max_codes']:.4f}, {r['max_codes_exact']:.4f} | "
            f"{r['load_before']:.1f}, {r['load_after']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def write_live_bench(out: Path, rows: list[dict]) -> None:
    """``live.csv`` and ``live.md`` in ``out``.

    Parameters
    ----------
    out
        The folder, existing; the two files are written whole or not at all.
    rows
        The rows of :func:`live_bench`, at least one.
    """
    with atomic_open(out / "live.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    write_text(out / "live.md", live_table(rows))
