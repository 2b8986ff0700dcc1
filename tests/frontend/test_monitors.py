"""Monitor Center names: a monitor is one file ``NAME.json`` of its folder, so a name that is
empty (an unset shell variable), holds a path separator or starts with ``.`` is refused naming
``--monitor`` before anything is written."""

from __future__ import annotations

from pathlib import Path

import pytest

from glarelab.display.calibration import Calibration
from glarelab.frontend.monitors import export_calibration, load_monitor

ROOT = Path(__file__).parents[2]
SPENCER_8BIT = ROOT / "calibrations" / "SYNTHETIC-spencer1995-50cd-8bit.json"


@pytest.mark.parametrize("name", ["", "  ", "a/b", "../lab", ".lab", "a\\b"])
def test_a_monitor_name_that_is_not_one_file_name_is_refused(tmp_path, name):
    calibration = Calibration.load(SPENCER_8BIT)
    with pytest.raises(ValueError, match=r"^--monitor .*monitor name") as refused:
        export_calibration(calibration, name, folder=tmp_path)
    assert repr(name) in str(refused.value)
    assert "partial" not in str(refused.value)
    assert list(tmp_path.rglob("*")) == []
    with pytest.raises(ValueError, match=r"^--monitor .*monitor name"):
        load_monitor(name, folder=tmp_path)
