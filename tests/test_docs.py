"""The documentation matches the code: generated references are current, every documented
command exists with the options it uses, and every command that needs no lab hardware (a
photometer, a participant at a full-screen window) runs as written."""

import glob
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from glarelab.cli import _parser
from glarelab.docs import data_reference, protocol_reference
from stimuli.exr import write_exr

ROOT = Path(__file__).parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def commands(document: Path) -> list[str]:
    text = document.read_text()
    found = []
    for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S):
        block = re.sub(r"\\\n\s*", " ", block)  # join continued lines
        for line in block.splitlines():
            line = line.split("  #")[0].strip()
            if line.startswith("glarelab "):
                found.append(line)
    return found


def needs_the_lab(command: str) -> bool:
    """A photometer, a participant, or data only a lab session makes."""
    words = shlex.split(command)
    if "measure" in words or "--fullscreen" in words or "--resume" in words:
        return True
    if words[1] == "run" and "--simulate" not in words and "--scripted-keys" not in words:
        return True
    return words[1] == "check-display"  # measures the lab's display (tested on Xvfb elsewhere)


def test_generated_references_are_current():
    assert (ROOT / "docs" / "protocols.md").read_text() == protocol_reference()
    assert (ROOT / "docs" / "data.md").read_text() == data_reference()


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_every_documented_command_parses(document):
    parser = _parser()
    for command in commands(document):
        words = shlex.split(command)[1:]
        try:
            parser.parse_args(words)
        except SystemExit as stop:
            pytest.fail(f"{document.name}: `{command}` does not parse (exit {stop.code})")


@pytest.fixture
def sandbox(tmp_path):
    for folder in ("protocols", "calibrations"):
        shutil.copytree(ROOT / folder, tmp_path / folder)
    shutil.copy(
        tmp_path / "calibrations" / "SYNTHETIC-yoshida2008-433cd-10bit.json",
        tmp_path / "calibrations" / "my-display.json",
    )
    scene = np.full((61, 61), 20.0, dtype=np.float32)
    scene[28:33, 28:33] = 5000.0
    write_exr(tmp_path / "scene.exr", scene)
    codes = range(0, 1024, 93)
    (tmp_path / "readings.csv").write_text(
        "code,luminance_cd_m2\n"
        + "".join(f"{c},{0.5 + 432.5 * (c / 1023) ** 2.2:.5f}\n" for c in codes)
    )
    (tmp_path / "keys.txt").write_text("space return y n y escape")
    return tmp_path


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_documented_commands_run(document, sandbox):
    environment = dict(os.environ)
    for command in commands(document):
        if needs_the_lab(command):
            continue
        words = shlex.split(command)
        expanded = []
        for word in words[1:]:
            matches = (
                sorted(glob.glob(str(sandbox / word))) if any(c in word for c in "*?") else []
            )
            expanded += [str(Path(m).relative_to(sandbox)) for m in matches] or [word]
        if words[1] == "analyse" and not any(
            w.endswith(".csv") and (sandbox / w).exists() for w in expanded
        ):
            continue  # its data come from lab sessions (checked by the parse test)
        if "--scheduler" in words:
            continue  # needs a Dask cluster (tests/test_power_commands.py starts one)
        if words[1] == "power":
            # the documented runs are a thousand replications on every core: run the same
            # command on two, here (tests/planning check the estimates themselves)
            expanded += ["--replications", "2", "--workers", "0"]
        if words[1] == "bench":
            # the documented runs take minutes to a quarter of an hour: run the same command
            # on the smallest workload (tests/test_bench.py checks the larger ones' rows)
            expanded += ["--only", "yoshida2008", "--no-spectral", "--repeats", "1"]
        if "--scripted-keys" in words:  # Xvfb is not the protocol's display: say so
            expanded += ["--accept-mismatch", "resolution", "refresh", "bit-depth"]
            expanded += ["--allow-unmeasured-refresh"]
        argv = [sys.executable, "-m", "glarelab", *expanded]
        if "--scripted-keys" in words and not os.environ.get("DISPLAY"):
            argv = [shutil.which("xvfb-run"), "-a", "-s", "-screen 0 1920x1080x24", *argv]
        done = subprocess.run(
            argv,
            cwd=sandbox,
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
            env=environment,
        )
        allowed = (0, 3) if "--scripted-keys" in words else (0,)  # 3: a dry run ends aborted
        assert done.returncode in allowed, (
            f"{document.name}: `{command}` failed:\n{done.stderr[-2000:]}"
        )
