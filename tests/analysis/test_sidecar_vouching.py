"""Each session file is vouched for by its sidecar: a file given twice is named, a sidecar of a
data format this version does not know, with a field of the wrong type or a value no session
writes (NaN, counterbalance 7), or that calls a simulated observer's session real is refused
naming the file and the field; a CSV without its sidecar is refused unless admitted, and then
listed."""

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from glarelab.analysis.dataset import DataError
from glarelab.analysis.load import load_sessions
from glarelab.protocols import load_protocol


@pytest.fixture(scope="module")
def luidolt(tmp_path_factory):
    """Two simulated Luidolt sessions (6 trials each)."""
    folder = tmp_path_factory.mktemp("luidolt")
    done = subprocess.run(
        [sys.executable, "-m", "glarelab", "run", "luidolt2020", "--simulate",
         "--participants", "2", "--seed", "1", "--out", str(folder)],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return load_protocol("luidolt2020"), sorted(folder.glob("*.csv"))


def edited(files, folder: Path, change: dict) -> list[Path]:
    """Copies of the sessions in ``folder``, the first one's sidecar with ``change``."""
    copies = []
    for path in files:
        shutil.copy(path, folder / path.name)
        shutil.copy(path.with_suffix(".json"), folder / path.with_suffix(".json").name)
        copies.append(folder / path.name)
    sidecar = copies[0].with_suffix(".json")
    sidecar.write_text(json.dumps(json.loads(sidecar.read_text()) | change))
    return copies


def test_the_same_file_given_twice_is_named(luidolt):
    protocol, files = luidolt
    with pytest.raises(DataError, match=re.escape(f"{files[0]}: given twice")):
        load_sessions(protocol, [*files, files[0]])
