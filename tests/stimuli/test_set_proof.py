"""A stimulus set is checked against its protocol, not only file by file: a manifest edited to
match edited files does not rebuild to itself, and neither ``stimuli verify`` nor a session
accepts it."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from glarelab.display.calibration import fit_calibration, read_readings
from glarelab.protocols import load_protocol
from glarelab.stimuli.exr import read_exr, write_exr
from glarelab.stimuli.stimulus_set import build_stimulus_set, prove_stimulus_set

ROOT = Path(__file__).parents[2]
READINGS = ROOT / "calibrations" / "example-readings.csv"
PYTHON = [sys.executable, "-m", "glarelab"]


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    folder = tmp_path_factory.mktemp("set") / "yoshida2008"
    build_stimulus_set(load_protocol("yoshida2008"), folder, progress=None)
    return folder


@pytest.fixture
def copy(genuine, tmp_path, monkeypatch):
    monkeypatch.setenv("GLARELAB_CACHE", str(tmp_path / "cache"))  # nothing proven yet
    folder = tmp_path / "set"
    shutil.copytree(genuine, folder)
    return folder


def edit_manifest(folder: Path, change) -> None:
    path = folder / "manifest.json"
    manifest = json.loads(path.read_text())
    change(manifest)
    path.write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")


def rehash(manifest: dict, folder: Path, name: str) -> None:
    manifest["files"][name] = hashlib.sha256((folder / name).read_bytes()).hexdigest()


def test_a_genuine_set_is_proven_and_remembered(copy):
    assert prove_stimulus_set(copy) == []
    assert list((copy.parent / "cache" / "proven-sets").iterdir())  # not rebuilt next time


def image_changed_and_rehashed(folder):
    name = "reference_gaussian_A.exr"
    image = read_exr(folder / name)
    write_exr(folder / name, (image * np.float32(1.5)).astype(np.float32))
    edit_manifest(folder, lambda m: rehash(m, folder, name))


def geometry_edited(folder):
    edit_manifest(folder, lambda m: m["geometry"].update(disk_diameter_deg=0.6))


def calibration_replaced(folder):
    lab = fit_calibration(read_readings(READINGS), bit_depth=10)
    edit_manifest(folder, lambda m: m.update(calibration=lab.to_json()))


def disk_luminance_times_ten(folder):
    def change(manifest):
        record = manifest["images"]["reference_gaussian_A"]
        record["disk_cd_m2"] = record["disk_cd_m2"] * 10

    edit_manifest(folder, change)


@pytest.mark.parametrize(
    ("tamper", "named"),
    [
        (image_changed_and_rehashed, "manifest.files.reference_gaussian_A.exr"),
        (geometry_edited, "manifest.geometry.disk_diameter_deg"),
        (calibration_replaced, "manifest.calibration"),
        (disk_luminance_times_ten, "manifest.images.reference_gaussian_A.disk_cd_m2"),
    ],
    ids=["image changed, sha256 updated", "geometry", "calibration block", "disk x10"],
)
def test_a_manifest_edited_to_match_is_refused_by_verify(copy, tamper, named):
    tamper(copy)
    problems = prove_stimulus_set(copy)
    assert problems and any(named in p for p in problems), problems
    done = subprocess.run(
        [*PYTHON, "stimuli", "verify", str(copy)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 1 and named in done.stderr, done.stderr
    assert "Traceback" not in done.stderr


def test_a_session_refuses_a_set_whose_manifest_does_not_rebuild(copy, tmp_path):
    disk_luminance_times_ten(copy)
    done = subprocess.run(
        [
            *PYTHON,
            "run",
            "yoshida2008",
            "--simulate",
            "--participant",
            "P01",
            "--stimuli",
            str(copy),
            "--out",
            str(tmp_path / "data"),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert "fails its manifest" in done.stderr and "disk_cd_m2" in done.stderr
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize("name", [".DS_Store", "._reference_gaussian_A.exr", "Thumbs.db"])
def test_a_file_browsers_own_file_in_a_copied_set_is_no_problem(copy, name):
    """A set copied with macOS Finder or opened in Windows Explorer gained a .DS_Store, ._NAME
    resource forks or Thumbs.db, and then failed verification, so sessions refused it."""
    (copy / name).write_bytes(b"\x00\x00\x00\x01Bud1")
    assert prove_stimulus_set(copy) == []
    (copy / "notes.txt").write_text("a person's file is still named\n")
    assert any("notes.txt" in p for p in prove_stimulus_set(copy))


def _exr_protocol(folder: Path, path: str) -> Path:
    """Yoshida's protocol with a uniform 50 cd/m² EXR background at ``path``, relative to the
    protocol file in ``folder``."""
    text = (ROOT / "src" / "glarelab" / "protocols" / "yoshida2008.toml").read_text()
    start = text.index("[background]")
    end = text.index("\n[", start + 1)
    table = f'[background]\nkind = "exr"\npath = "{path}"\npixel_deg = 0.2\n'
    protocol = folder / "proto" / "exrbg.toml"
    (folder / "proto" / path).parent.mkdir(parents=True, exist_ok=True)
    protocol.write_text(text[:start] + table + text[end:])
    write_exr(folder / "proto" / path, np.full((16, 16), 50.0, np.float32))
    return protocol


@pytest.mark.parametrize("relative", ["background.exr", "images/bg.exr"])
def test_a_set_with_an_exr_background_is_proven_anywhere(relative, tmp_path, monkeypatch):
    """The proof read the background from the working folder: the set was unprovable there,
    or 'does not match a rebuild' beside another bg.exr; it keeps its own copy now (in a folder
    of its own: the set has an image named background.exr)."""
    monkeypatch.setenv("GLARELAB_CACHE", str(tmp_path / "cache"))
    folder = tmp_path / "set"
    build_stimulus_set(load_protocol(_exr_protocol(tmp_path, relative)), folder, progress=None)
    kept = folder / "backgrounds" / relative
    assert kept.read_bytes() == (tmp_path / "proto" / relative).read_bytes()
    elsewhere = tmp_path / "elsewhere"
    (elsewhere / relative).parent.mkdir(parents=True)
    write_exr(elsewhere / relative, np.full((16, 16), 20.0, np.float32))
    monkeypatch.chdir(elsewhere)
    shutil.rmtree(tmp_path / "cache")  # another machine: nothing proven
    assert prove_stimulus_set(folder) == []
    write_exr(kept, np.full((16, 16), 20.0, np.float32))  # a changed background
    changed = f"backgrounds/{relative}: changed (sha256 differs from the manifest)"
    assert prove_stimulus_set(folder) == [changed]


def test_a_background_outside_the_protocols_folder_is_refused_before_the_build(tmp_path):
    protocol = load_protocol(_exr_protocol(tmp_path / "a", "../bg.exr"))
    with pytest.raises(ValueError, match=r"background.path = '\.\./bg.exr': .*must not leave"):
        build_stimulus_set(protocol, tmp_path / "set", progress=None)
    assert not (tmp_path / "set").exists()


def test_a_background_inside_the_set_it_would_replace_is_refused(tmp_path, monkeypatch):
    """A protocol pointing at the set's own copy of its background (kept as the master),
    rebuilt into that set: the rebuild replaced the folder whole and deleted the only copy of
    the EXR, said '48 files', and the set still verified."""
    monkeypatch.setenv("GLARELAB_CACHE", str(tmp_path / "cache"))
    folder = tmp_path / "set"
    build_stimulus_set(load_protocol(_exr_protocol(tmp_path, "bg.exr")), folder, progress=None)
    master = folder / "backgrounds" / "bg.exr"
    before = master.read_bytes()
    text = (tmp_path / "proto" / "exrbg.toml").read_text()
    inside = tmp_path / "proto" / "inside.toml"
    inside.write_text(text.replace('path = "bg.exr"', f'path = "{master}"'))
    with pytest.raises(ValueError, match=rf"^{re.escape(str(master))} is inside .*set, which the "
                       r"stimulus set replaces whole: give another folder \(nothing was changed\)"):  # fmt: skip
        build_stimulus_set(load_protocol(inside), folder, progress=None)
    assert master.read_bytes() == before
    assert prove_stimulus_set(folder) == []
