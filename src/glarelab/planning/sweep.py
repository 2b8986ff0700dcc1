"""The stimulus sets of a grid of protocol parameters, each built (and optionally simulated) as
one task on Dask.

For the grid of :func:`glarelab.planning.grid.grid`, point ``i`` is built into ``OUT/sets/iii/``: a
stimulus set with its own ``manifest.json`` (the point's validated protocol, its hash, every
file's sha256; :func:`glarelab.stimuli.stimulus_set.build_stimulus_set`). With ``simulate = N``,
``N`` simulated observers run on it (``OUT/simulated/iii/data``), are analysed
(``OUT/simulated/iii/report``, :func:`glarelab.analysis.report.write_report`) and the tests of the
analysis are listed in ``OUT/effects.csv`` (:mod:`glarelab.planning.effects`). ``OUT/index.csv``
(and ``index.json``) has one row per point: its number, the value of each key varied, its folder,
the protocol's and the manifest's sha256, the number of images, and the build time.

A point whose set is already in place, verified against its manifest and built from the same
protocol, is not built again, and a point already in ``OUT/points.jsonl`` is not run again: an
interrupted sweep resumes.
"""

from __future__ import annotations

import hashlib
import json
import math
import shutil
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import pandas as pd

from glarelab.files.atomic import write_bytes, write_text
from glarelab.files.inputs import loads_json
from glarelab.planning.grid import Point, Setting, grid

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["MAX_POINTS", "SweepJob", "prepare", "sweep"]

MAX_POINTS = 1000
"""The most points a sweep builds (the sets are numbered with three digits, ``sets/iii``)."""


def _manifest_sha(folder: Path) -> str:
    return hashlib.sha256((folder / "manifest.json").read_bytes()).hexdigest()


def _in_place(folder: Path, protocol: Protocol) -> bool:
    from glarelab.stimuli.stimulus_set import verify_stimulus_set

    if not (folder / "manifest.json").is_file() or verify_stimulus_set(folder):
        return False
    path = folder / "manifest.json"
    manifest = loads_json(path.read_text(encoding="utf-8"), source=path)
    return manifest.get("protocol_sha256") == protocol.sha256


class SweepJob:
    """The points of a grid as tasks of :func:`glarelab.planning.execute.run_tasks`.

    Parameters
    ----------
    points
        The grid's points (:func:`prepare`); a task is a point's index.
    out
        The sweep's folder: sets in ``sets/NNN``, simulations in ``simulated/NNN``.
    simulate
        Simulated observers per point; 0: build only.
    seed
        The simulated observers' seed.
    """

    kind = "sweep"

    def __init__(self, points: Sequence[Point], out: Path, *, simulate: int, seed: int):
        self.points = {p.index: p for p in points}
        self.out = Path(out)
        self.simulate = simulate
        self.seed = seed

    def run(self, index: int) -> dict:
        """Build point ``index``'s set (unless in place), simulate it if asked.

        Parameters
        ----------
        index
            The point's number in the grid.

        Returns
        -------
        dict
            The index's row: ``point``, ``values``, ``protocol_sha256``, the set's ``folder``
            and ``manifest_sha256`` (None without images), ``images`` (not counting
            components), ``build_s`` (seconds) and ``effects``
            (:func:`glarelab.planning.effects.effects` of the simulation; empty without).
        """
        from glarelab.stimuli.stimulus_set import (
            build_stimulus_set,
            default_calibration,
            shows_images,
        )

        point = self.points[index]
        protocol = point.protocol
        record = {
            "point": index,
            "values": point.values,
            "protocol_sha256": protocol.sha256,
            "folder": None,
            "manifest_sha256": None,
            "images": 0,
            "build_s": 0.0,
            "effects": [],
        }
        folder = None
        if shows_images(protocol):
            folder = self.out / "sets" / f"{index:03d}"
            start = time.perf_counter()
            if not _in_place(folder, protocol):  # built beside it and put in place whole; a
                # build killed before leaves its staging folder, cleared by the next one
                build_stimulus_set(
                    protocol, folder, calibration=default_calibration(protocol), progress=None
                )
            manifest = loads_json((folder / "manifest.json").read_text(encoding="utf-8"))
            record |= {
                "folder": str(folder.relative_to(self.out)),
                "manifest_sha256": _manifest_sha(folder),
                "images": sum(1 for i in manifest["images"].values() if i["kind"] != "component"),
                "build_s": round(time.perf_counter() - start, 3),
            }
        if self.simulate:
            record["effects"] = self._simulate(index, protocol, folder)
        return record

    def _simulate(self, index: int, protocol: Protocol, folder: Path | None) -> list[dict]:
        from glarelab.analysis.load import load_sessions
        from glarelab.analysis.paradigms import paradigm_analysis
        from glarelab.analysis.report import write_report
        from glarelab.planning.effects import effects
        from glarelab.planning.simulate import _simulate_sessions

        where = self.out / "simulated" / f"{index:03d}"
        shutil.rmtree(where, ignore_errors=True)
        data = where / "data"
        ids = [f"sim{number:02d}" for number in range(1, self.simulate + 1)]
        _simulate_sessions(
            protocol, ids, seed=self.seed, out=data, stimuli=folder, looks_at=folder
        )
        csvs = sorted(data.glob("*.csv"))
        write_report(protocol, csvs, where / "report", stimuli=folder)
        tables = paradigm_analysis(protocol).tests(load_sessions(protocol, csvs), protocol)
        return effects(protocol, tables, self.simulate)


def prepare(
    protocol: str | Path,
    settings: Sequence[Setting],
    out: str | Path,
    *,
    simulate: int = 0,
    seed: int = 1,
) -> tuple[list[Point], dict]:
    """Check a sweep before it runs, writing nothing: the grid's points, each validated, and
    the sweep's record (``sweep.json``).

    Parameters
    ----------
    protocol
        A shipped study's name or a protocol TOML file.
    settings
        The keys varied and their values (:func:`glarelab.planning.grid.parse_setting`).
    out
        The sweep's folder; one holding a sweep of the same inputs is resumed.
    simulate
        Simulated observers per point: 0 (default, build only) or at least 2.
    seed
        The simulated observers' seed; default 1.

    Returns
    -------
    points : list of Point
        The grid's points, each protocol validated.
    record : dict
        What the sweep depends on, as ``sweep.json`` holds it.

    Raises
    ------
    glarelab.planning.grid.GridError
        For a bad key or value, or points that do not validate.
    ValueError
        For a protocol that shows no images without ``simulate``, ``simulate`` of 1, a point
        whose observers cannot be simulated, or an ``out`` holding a sweep of other inputs
        (naming what differs: the study, each key whose values differ, the same points in
        another order, the seed or the simulation).
    """
    from glarelab.experiments.paradigms import paradigm_run
    from glarelab.stimuli.stimulus_set import shows_images

    if isinstance(simulate, bool) or not isinstance(simulate, int) or simulate < 0:
        raise ValueError(f"simulate must be a whole number >= 0; got {simulate!r}")
    if simulate == 1:
        raise ValueError("simulate: the analysis needs at least 2 simulated observers; got 1")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed must be a whole number >= 0; got {seed!r}")
    size = math.prod(len(s.values) for s in settings)
    if size > MAX_POINTS:
        raise ValueError(
            f"the grid has {size} points ({' × '.join(str(len(s.values)) for s in settings)}); "
            f"a sweep builds at most {MAX_POINTS}: split it into several"
        )
    points = grid(protocol, settings)
    first = points[0].protocol
    if not shows_images(first) and not simulate:
        raise ValueError(
            f"the {first.study} protocol's paradigm ({first.paradigm}) shows no images: there "
            "are no stimulus sets to build; add --simulate N to simulate each point"
        )
    if simulate:
        for point in points:
            observer = paradigm_run(point.protocol).observer
            if observer is None:
                raise ValueError(
                    f"the {point.protocol.paradigm} paradigm has no simulated observer"
                )
            observer.check(point.protocol)
    config = {
        "format": "glarelab sweep v1",
        "points": [{"point": p.index, "protocol_sha256": p.protocol.sha256} for p in points],
        "simulate": simulate,
        "seed": seed,
        "study": first.study,
        "grid": [[s.key, [_shown(v) for v in s.values]] for s in settings],
    }
    path = Path(out) / "sweep.json"
    if path.is_file():
        try:
            before = loads_json(path.read_text(encoding="utf-8"))
        except (json.JSONDecodeError, UnicodeDecodeError):
            before = None
        named = {k: v for k, v in config.items() if k not in ("study", "grid")}
        if before not in (config, named):  # named: written before the grid was recorded
            raise ValueError(
                f"{out} holds a sweep of {_other_inputs(before, config)}: give another --out, "
                "or delete it to start again"
            )
    return points, config


def _other_inputs(before, config: dict) -> str:
    """What differs between an earlier sweep's ``sweep.json`` and this one's: the grid or
    study (:func:`_other_points`), the seed and the simulation named with their values."""
    if not isinstance(before, dict):
        return "other inputs (its sweep.json cannot be read)"
    parts = []
    if before.get("points") != config["points"]:
        parts.append(_other_points(before, config))
    for key in ("simulate", "seed"):
        if before.get(key) != config[key]:
            parts.append(f"{key} {before.get(key)!r} then, {config[key]!r} now")
    if before.get("format") != config["format"]:
        parts.append(f"another format ({before.get('format')!r})")
    return f"other inputs ({'; '.join(parts) or 'sweep.json edited'})"


def _shown(value) -> str:
    """A grid value as ``--set`` takes it: ``0.2``, ``photopic``, ``[220, 4000]``."""
    return value if isinstance(value, str) else json.dumps(value, default=str)


def _other_points(before: dict, config: dict) -> str:
    """How an earlier sweep's points differ from this one's: the protocol's study, each key
    whose values differ (``study.seed = 1,2 then, 1,3 now``), or the same points in another
    order (resumed only in the earlier order: points are numbered in it)."""
    grid = before.get("grid")
    if not isinstance(grid, list) or not all(
        isinstance(g, list) and len(g) == 2 and isinstance(g[1], list) for g in grid
    ):  # a sweep.json written before the grid was recorded in it
        return "another grid or protocol"
    parts = []
    if before.get("study") != config["study"]:
        parts.append(f"protocol {before.get('study')} then, {config['study']} now")
    then, now = {k: v for k, v in grid}, dict(config["grid"])
    if list(then) != list(now) and set(then) == set(now):
        parts.append(f"keys in the order {', '.join(then)} then, {', '.join(now)} now")
    for key in [*now, *(k for k in then if k not in now)]:
        was = ",".join(map(str, then[key])) if key in then else "(not varied)"
        is_ = ",".join(now[key]) if key in now else "(not varied)"
        if was != is_:
            parts.append(f"{key} = {was} then, {is_} now")
    try:
        shas = sorted(p["protocol_sha256"] for p in before["points"])
    except (KeyError, TypeError):
        shas = None
    if shas == sorted(p["protocol_sha256"] for p in config["points"]):
        return (
            f"the same points in another order, {'; '.join(parts)}: give them in the earlier "
            "order to resume it"
        )
    if not parts:
        parts.append(f"the {config['study']} protocol edited (its points' sha256 differ)")
    return "; ".join(parts)


def sweep(
    protocol: str | Path,
    settings: Sequence[Setting],
    out: str | Path,
    *,
    simulate: int = 0,
    seed: int = 1,
    client=None,
    log: Callable[[str], None] = print,
    progress: bool = True,
) -> pd.DataFrame:
    """Build (and with ``simulate`` > 0, simulate) every point of a grid; return the index.

    Parameters
    ----------
    protocol
        A shipped study's name or a protocol TOML file.
    settings
        The keys varied and their values (:func:`glarelab.planning.grid.parse_setting`).
    out
        Output folder (module docstring); a rerun resumes it.
    simulate, seed
        Simulated observers per point (0: build only; at least 2 to analyse) and their seed.
    client
        A :class:`distributed.Client`, or None to run here without Dask.
    log, progress
        Messages and the progress bar.

    Raises
    ------
    glarelab.planning.grid.GridError, ValueError
        As :func:`prepare`, before anything is built or written.
    """
    from glarelab.planning.execute import Progress, ResultLog, run_tasks

    points, config = prepare(protocol, settings, out, simulate=simulate, seed=seed)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "sweep.json", json.dumps(config, indent=2, sort_keys=True) + "\n")
    log(f"{len(points)} points on the grid of {', '.join(s.key for s in settings)}")
    job = SweepJob(points, out, simulate=simulate, seed=seed)
    with ResultLog(out / "points.jsonl") as results:
        run_tasks(
            job,
            [p.index for p in points],
            results,
            client=client,
            what="points",
            progress=Progress if progress else None,
        )
        records = results.sorted(p.index for p in points)
    rows, effect_rows = [], []
    for record in records:
        row = {"point": record["point"]}
        row |= {key: json.dumps(value) for key, value in record["values"].items()}
        row |= {k: record[k] for k in ("folder", "protocol_sha256", "manifest_sha256", "images")}
        row["build_s"] = record["build_s"]
        rows.append(row)
        effect_rows += [{"point": record["point"], **e} for e in record["effects"]]
    index = pd.DataFrame(rows)
    write_bytes(out / "index.csv", index.to_csv(index=False).encode())
    write_text(out / "index.json", json.dumps(records, indent=2, sort_keys=True) + "\n")
    if effect_rows:
        table = pd.DataFrame(effect_rows).to_csv(index=False, float_format="%.6g")
        write_bytes(out / "effects.csv", table.encode())
    return index
