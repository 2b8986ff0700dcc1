"""The distribution a pip user gets: the sdist and the wheel built from it pass ``twine check``,
carry the license (BSD-3-Clause, its text inside the wheel), the author and the classifiers,
and ship the example scenes and readings, which ``glarelab examples`` writes out from the
installed package as from a clone; ``glarelab protocol copy`` writes out a shipped protocol."""

from __future__ import annotations

import email
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def dist(tmp_path_factory):
    pytest.importorskip("build")
    out = tmp_path_factory.mktemp("dist")
    source = tmp_path_factory.mktemp("clone") / "glarelab"
    # a clone's files (a lab's own files in the checkout are not in the sdist anyway)
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT, capture_output=True, text=True, check=True,
    ).stdout.split("\n")  # fmt: skip
    for name in filter(None, listed):
        if (ROOT / name).is_file():
            (source / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, source / name)
    built = subprocess.run(
        [sys.executable, "-m", "build", "--outdir", str(out), str(source)],
        capture_output=True, text=True, timeout=900, check=False,
    )  # fmt: skip
    assert built.returncode == 0, built.stdout[-3000:] + built.stderr[-3000:]
    return out


def test_twine_check_passes(dist):
    pytest.importorskip("twine")
    files = sorted(str(p) for p in dist.iterdir())
    assert any(f.endswith(".whl") for f in files) and any(f.endswith(".tar.gz") for f in files)
    checked = subprocess.run(
        [sys.executable, "-m", "twine", "check", "--strict", *files],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert checked.returncode == 0, checked.stdout + checked.stderr
    assert checked.stdout.count("PASSED") == 2


def test_the_wheel_carries_the_license_author_and_classifiers(dist):
    (wheel,) = dist.glob("glarelab-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        licence = [n for n in names if n.endswith(".dist-info/licenses/LICENSE")]
        assert licence, names
        text = archive.read(licence[0]).decode()
        metadata = email.message_from_bytes(
            archive.read(next(n for n in names if n.endswith(".dist-info/METADATA")))
        )
    assert "BSD 3-Clause License" in text and "glarelab developers" in text
    assert text == (ROOT / "LICENSE").read_text()
    assert metadata["License-Expression"] == "BSD-3-Clause"
    assert metadata["License-File"] == "LICENSE"
    assert metadata["Author"] == "glarelab developers"
    classifiers = metadata.get_all("Classifier")
    assert "Intended Audience :: Science/Research" in classifiers
    assert "Topic :: Scientific/Engineering" in classifiers
    # shipped with the package: the examples and the readings, not a lab's own calibrations
    shipped = sorted(n for n in names if n.startswith("glarelab/shipped/"))
    assert shipped == [
        "glarelab/shipped/calibrations/README.md",
        "glarelab/shipped/calibrations/SYNTHETIC-spencer1995-50cd-8bit.json",
        "glarelab/shipped/calibrations/SYNTHETIC-yoshida2008-433cd-10bit.json",
        "glarelab/shipped/calibrations/example-readings-night2026.csv",
        "glarelab/shipped/calibrations/example-readings-spencer1995.csv",
        "glarelab/shipped/calibrations/example-readings.csv",
        "glarelab/shipped/examples/night.exr",
        "glarelab/shipped/examples/scene.exr",
    ]


def _run(args, *, cwd, pythonpath):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"} | {"PYTHONPATH": pythonpath}
    return subprocess.run(
        [sys.executable, "-m", "glarelab", *args],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip


def test_a_pip_user_writes_out_the_examples_and_a_protocol(dist, tmp_path):
    (wheel,) = dist.glob("glarelab-*.whl")
    installed = tmp_path / "site"
    with zipfile.ZipFile(wheel) as archive:  # a pure-Python wheel, as pip unpacks it
        archive.extractall(installed)
    user = tmp_path / "user"
    user.mkdir()
    done = _run(["examples", "lab"], cwd=user, pythonpath=str(installed))
    assert done.returncode == 0, done.stderr
    for name in ("examples/scene.exr", "calibrations/example-readings.csv"):
        assert (user / "lab" / name).read_bytes() == (ROOT / name).read_bytes()
    again = _run(["examples", "lab"], cwd=user, pythonpath=str(installed))
    assert again.returncode != 0 and "never copied over a file" in again.stderr
    copied = _run(["protocol", "copy", "spencer1995", "mine.toml"], cwd=user,
                  pythonpath=str(installed))  # fmt: skip
    assert copied.returncode == 0, copied.stderr
    assert (user / "mine.toml").read_bytes() == (
        ROOT / "src" / "glarelab" / "protocols" / "spencer1995.toml"
    ).read_bytes()
    refused = _run(["protocol", "copy", "spencer1995", "mine.toml"], cwd=user,
                   pythonpath=str(installed))  # fmt: skip
    assert refused.returncode != 0 and "exists" in refused.stderr
    checked = _run(["protocol", "check", "mine.toml"], cwd=user, pythonpath=str(installed))
    assert checked.returncode == 0, checked.stderr
    # glarelab docs makes no docs/ folder where it is run, unless asked
    docs = _run(["docs"], cwd=user, pythonpath=str(installed))
    assert docs.returncode != 0 and "give --out FOLDER" in docs.stderr
    assert not (user / "docs").exists()
    asked = _run(["docs", "--out", "reference"], cwd=user, pythonpath=str(installed))
    assert asked.returncode == 0, asked.stderr
    assert (user / "reference" / "data.md").is_file()
