"""``glarelab examples DEST`` writes every example file the README's commands use (the README
tells a pip-installed lab to run them in DEST)."""

import re
from pathlib import Path

from glarelab.files.shipped import copy_shipped

ROOT = Path(__file__).parents[2]


def test_examples_writes_every_example_file_the_readme_uses(tmp_path):
    """Attack case m028: the Spencer and night readings were missing."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    used = set(re.findall(r"(?:examples|calibrations)/[\w.-]+\.(?:csv|exr)", readme))
    shipped = {p.relative_to(ROOT).as_posix() for p in ROOT.glob("calibrations/example-*.csv")}
    assert {
        "calibrations/example-readings-spencer1995.csv",
        "calibrations/example-readings-night2026.csv",
    } <= used & shipped
    written = {p.relative_to(tmp_path).as_posix() for p in copy_shipped(tmp_path)}
    assert {u for u in used if (ROOT / u).is_file()} <= written
