"""``glarelab calibrate``'s commands refuse what they cannot do right, in one line naming the
argument, before anything is written."""

from __future__ import annotations

from pathlib import Path

import pytest

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


@pytest.mark.parametrize(
    ("simulate", "named"),
    [(["0.1", "100", "2.2"], "WHITE (0.1 cd/m²) must be above BLACK (100 cd/m²)"),
     (["100", "100", "2.2"], "WHITE (100 cd/m²) must be above BLACK"),
     (["100", "0.1", "0"], "GAMMA must be > 0")],
)  # fmt: skip
def test_measure_refuses_a_simulated_display_before_measuring(
    tmp_path, capsys, monkeypatch, simulate, named
):
    # white below black, or gamma 0, ran the whole measurement in a window, then blamed
    # "photometer drift" for readings that could never be fitted
    import glarelab.frontend.measure

    def measured(*args, **kwargs):
        raise AssertionError("the measurement ran")

    monkeypatch.setattr(glarelab.frontend.measure, "run_measurement", measured)
    line = refused(["calibrate", "measure", "--windowed", "--bit-depth", "8", "--points", "5",
                    "--out", tmp_path / "m.json", "--simulate", *simulate], capsys)  # fmt: skip
    assert line.startswith(f"glarelab calibrate: --simulate {' '.join(simulate)}: "), line
    assert named in line
    assert list(tmp_path.iterdir()) == []
