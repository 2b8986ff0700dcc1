"""Test-wide settings: one cache of simulated observers' stimulus sets per test run, in a
temporary folder (never the user's ~/.cache)."""

import csv
import json
import os
from pathlib import Path

import pytest


@pytest.fixture(scope="session", autouse=True)
def stimulus_set_cache(tmp_path_factory):
    folder = tmp_path_factory.mktemp("glarelab-cache")
    previous = os.environ.get("GLARELAB_CACHE")
    os.environ["GLARELAB_CACHE"] = str(folder)
    yield folder
    if previous is None:
        os.environ.pop("GLARELAB_CACHE", None)
    else:
        os.environ["GLARELAB_CACHE"] = previous


def small_night_protocol(**scene) -> str:
    """protocols/night2026.toml with a small, short scene (tests render it in seconds):
    64 × 48 px, three frames of 0.1 s, and ``scene`` keys replaced (a value of None drops the
    key)."""
    from pathlib import Path

    text = (
        Path(__file__).parents[1] / "src" / "glarelab" / "protocols" / "night2026.toml"
    ).read_text()
    values = {
        "size_px": "[64, 48]",
        "pixel_deg": "0.1",
        "seconds": "0.3",
        "start_cd_m2": "100.0",
    } | {k: (None if v is None else repr(v).replace("'", '"')) for k, v in scene.items()}
    if scene.get("sequence", "enter_dark") != "enter_dark":  # only enter_dark reads it
        values["start_cd_m2"] = None
    if scene.get("sequence") == "still" and "frame_rate_hz" not in scene:  # one frame
        values["frame_rate_hz"] = None
    lines = []
    in_scene = False
    for line in text.splitlines():
        if line.startswith("["):
            if in_scene:  # keys not in the file go at the end of [scene]
                lines += [f"{k} = {v}" for k, v in values.items() if v is not None]
                values = {}
            in_scene = line.strip() == "[scene]"
        key = line.split("=")[0].strip()
        if in_scene and key in values:
            if values[key] is not None:
                lines.append(f"{key} = {values.pop(key)}")
            else:
                values.pop(key)
            continue
        lines.append(line)
    return "\n".join(lines) + "\n"


@pytest.fixture
def night_toml(tmp_path):
    """A small night study's protocol file (see :func:`small_night_protocol`)."""
    path = tmp_path / "night_small.toml"
    path.write_text(small_night_protocol())
    return path


def reseal(csv_path) -> None:
    """Record in a session's sidecar the digests of its CSV's rows as they are now
    (``row_sha256``, trial n at entry n), as a session writes them: a test that forges a
    session (rows cut, renamed or changed to make its case) seals it again, so that the check
    it tests meets the case, not the check that the rows are the ones a session wrote."""
    from glarelab.protocols import row_digest

    path = Path(csv_path)
    with path.open(newline="", encoding="utf-8") as handle:
        header, *records = list(csv.reader(handle))
    if "trial" not in header:  # a header moved away from the first line: nothing to seal
        return
    rows = [dict(zip(header, cells, strict=False)) for cells in records]
    rows = sorted((row for row in rows if row.get("trial", "").isdigit()),
                  key=lambda row: int(row["trial"]))  # fmt: skip
    sidecar_path = path.with_suffix(".json")
    sidecar = json.loads(sidecar_path.read_text(encoding="utf-8"))
    sidecar["row_sha256"] = [row_digest(row[name] for name in header) for row in rows]
    sidecar_path.write_text(json.dumps(sidecar, indent=2), encoding="utf-8")
