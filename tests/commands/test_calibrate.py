"""``glarelab calibrate``'s commands refuse what they cannot do right, in one line naming the
argument, before anything is written."""

from __future__ import annotations

from pathlib import Path

from glarelab.cli import main

ROOT = Path(__file__).parents[2]
SPENCER_8BIT = ROOT / "calibrations" / "SYNTHETIC-spencer1995-50cd-8bit.json"


def refused(argv, capsys) -> str:
    capsys.readouterr()
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    assert status == 2, err
    lines = [line for line in err.strip().splitlines() if not line.startswith("[glarelab]")]
    assert len(lines) == 1, err
    return lines[0]


def test_export_monitor_refuses_a_protocol_of_another_display(tmp_path, capsys):
    # Yoshida's display is 10-bit with a 433 cd/m² white; this calibration is 8-bit, 50 cd/m²:
    # the monitor would get Yoshida's geometry and a calibration that cannot show his images
    folder = tmp_path / "monitors"
    folder.mkdir()
    line = refused(
        ["calibrate", "export-monitor", SPENCER_8BIT, "--monitor", "lab",
         "--protocol", "yoshida2008", "--monitor-folder", folder], capsys,
    )  # fmt: skip
    assert "--protocol yoshida2008" in line
    assert "8-bit" in line and "10-bit" in line and "433" in line
    assert list(folder.iterdir()) == []
