"""PsychoPy's Monitor Center both ways: a glarelab calibration exported to a monitor is read by
PsychoPy's own ``Monitor`` (gamma grid, measurements, size, width, distance), a monitor given
with ``--monitor`` sets a study's geometry and its images' encoding, and every glarelab window
has a monitor, so PsychoPy no longer warns "Monitor specification not found". Each monitor lives
in a temporary folder (``--monitor-folder``), never the user's Monitor Center.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.cli import main
from glarelab.display.calibration import Calibration, fit_calibration, read_readings
from glarelab.protocols import load_protocol

from .xscreen import XScreen

ROOT = Path(__file__).parents[2]
SPENCER_READINGS = ROOT / "calibrations" / "example-readings-spencer1995.csv"
# Spencer's display: an 18-inch visible diagonal, 1280 × 1024 square pixels (5:4)
WIDTH_CM = 18 * 2.54 * 5 / np.sqrt(41)

pytest.importorskip("psychopy")


@pytest.fixture
def spencer_calibration(tmp_path) -> Path:
    path = tmp_path / "spencer.json"
    fit_calibration(read_readings(SPENCER_READINGS), bit_depth=8).save(path)
    return path


def test_an_exported_calibration_is_psychopys_own_monitor(tmp_path, spencer_calibration):
    monitors = tmp_path / "monitors"
    monitors.mkdir()
    assert main(["calibrate", "export-monitor", str(spencer_calibration), "--monitor", "crt",
                 "--protocol", "spencer1995", "--monitor-folder", str(monitors)]) == 0  # fmt: skip
    # PsychoPy reads the file from its own folder, as Monitor Center does
    from psychopy.monitors import Monitor, calibTools
    from psychopy.monitors.calibTools import gammaFun

    saved = calibTools.monitorFolder
    calibTools.monitorFolder = str(monitors)
    try:
        monitor = Monitor("crt")
    finally:
        calibTools.monitorFolder = saved
    protocol = load_protocol("spencer1995")
    assert monitor.getSizePix() == [1280, 1024]
    assert monitor.getDistance() == pytest.approx(60.0)  # the protocol's 0.6 m
    assert monitor.getWidth() == pytest.approx(WIDTH_CM)
    calibration = Calibration.load(spencer_calibration)
    assert_allclose(monitor.getLumsPre(), [v for _, v in calibration.readings])
    assert_allclose(monitor.getLevelsPre(), [c for c, _ in calibration.readings])  # 8-bit
    # PsychoPy's own gamma function (eq. 4) over the grid is the gain-offset-gamma fit
    grid = monitor.getGammaGrid()
    gog = fit_calibration(list(calibration.readings), bit_depth=8, method="gog")
    codes = np.arange(256)
    psychopy_lum = gammaFun(codes / 255, *grid[0, :3], eq=4, a=grid[0, 3], b=grid[0, 4],
                            k=grid[0, 5])  # fmt: skip
    assert_allclose(psychopy_lum, gog.decode(codes), rtol=1e-5)
    assert protocol["display"]["max_cd_m2"] == pytest.approx(grid[0, 1], rel=0.01)
    # a second export keeps the first calibration, and the note a user added to it, under its
    # name; the new one, of the same glarelab calibration, gets the next
    saved = json.loads((monitors / "crt.json").read_text())
    (first,) = saved
    saved[first]["notes"] = "the lab's note: measured after the lamp was changed"
    (monitors / "crt.json").write_text(json.dumps(saved))
    assert main(["calibrate", "export-monitor", str(spencer_calibration), "--monitor", "crt",
                 "--monitor-folder", str(monitors)]) == 0  # fmt: skip
    again = json.loads((monitors / "crt.json").read_text())
    assert len(again) == 2 and sorted(again)[0] == first  # the new one sorts last: current
    assert again[first]["notes"] == "the lab's note: measured after the lamp was changed"


def test_the_calibration_exported_last_is_the_one_a_build_uses(tmp_path, spencer_calibration):
    """Named ``glarelab DATE HASH``, two calibrations exported on one day sorted by their
    readings' hash, and PsychoPy makes the name that sorts last current: a build used the
    older calibration whenever its hash sorted later."""
    from glarelab.frontend.monitors import load_monitor, monitor_display

    monitors = tmp_path / "monitors"
    monitors.mkdir()
    readings = read_readings(SPENCER_READINGS)
    names = []
    for scale in (1.0, 0.9, 1.1, 0.8):  # hashes in every order
        path = tmp_path / f"c{scale}.json"
        fit_calibration([(c, v * scale) for c, v in readings], bit_depth=8).save(path)
        assert main(["calibrate", "export-monitor", str(path), "--monitor", "crt",
                     "--monitor-folder", str(monitors)]) == 0  # fmt: skip
        current = monitor_display(load_monitor("crt", folder=monitors))["calibration"]
        assert current not in names and current.endswith(
            Calibration.load(path).readings_sha256[:12]
        )
        names.append(current)
    assert names == sorted(names)
    saved = json.loads((monitors / "crt.json").read_text())
    saved["zz the lab's own"] = saved[names[0]]  # a name that sorts after any export
    (monitors / "crt.json").write_text(json.dumps(saved))
    before = (monitors / "crt.json").read_bytes()
    assert main(["calibrate", "export-monitor", str(spencer_calibration), "--monitor", "crt",
                 "--monitor-folder", str(monitors)]) == 2  # fmt: skip
    assert (monitors / "crt.json").read_bytes() == before


def test_a_monitor_sets_a_sets_geometry_and_encoding(tmp_path, spencer_calibration):
    monitors = tmp_path / "monitors"
    monitors.mkdir()
    assert main(["calibrate", "export-monitor", str(spencer_calibration), "--monitor", "crt",
                 "--protocol", "spencer1995", "--monitor-folder", str(monitors)]) == 0  # fmt: skip
    data = json.loads((monitors / "crt.json").read_text())
    (calibration_name,) = data
    data[calibration_name]["distance"] = 90.0  # the lab moved the chin rest
    (monitors / "crt.json").write_text(json.dumps(data))
    out = tmp_path / "set"
    assert main(["stimuli", "build", "spencer1995", "--monitor", "crt", "--monitor-folder",
                 str(monitors), "--out", str(out)]) == 0  # fmt: skip
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["protocol"]["viewing"]["distance_m"] == pytest.approx(0.9)
    assert manifest["protocol"]["display"]["resolution_px"] == [1280, 1024]
    pitch_mm = 18 * 25.4 / np.sqrt(1280**2 + 1024**2)
    assert manifest["protocol"]["display"]["pixel_pitch_mm"] == pytest.approx(pitch_mm)
    # the monitor's luminance measurements encode the images: the exported calibration's
    exported = Calibration.load(spencer_calibration)
    assert manifest["calibration"]["readings"] == [list(r) for r in exported.readings]
    assert "Monitor Center monitor 'crt'" in manifest["calibration"]["label"]


def test_a_monitor_without_luminance_or_that_is_not_there_is_refused(tmp_path, capsys):
    monitors = tmp_path / "monitors"
    monitors.mkdir()
    assert main(["stimuli", "build", "spencer1995", "--monitor", "nowhere", "--monitor-folder",
                 str(monitors), "--out", str(tmp_path / "set")]) == 2  # fmt: skip
    assert "--monitor 'nowhere': no such monitor in Monitor Center's folder" in (
        capsys.readouterr().err
    )
    from psychopy.monitors import calibTools

    blank = {"2026_01_01 10:00": {"sizePix": [1280, 1024], "width": 37.0, "distance": 60.0,
                                  "gammaGrid": [[0, 1, 1]] * 4, "calibDate": 0}}  # fmt: skip
    (monitors / "blank.json").write_text(json.dumps(blank))
    assert calibTools.monitorFolder != str(monitors)  # nothing global was changed
    assert main(["stimuli", "build", "spencer1995", "--monitor", "blank", "--monitor-folder",
                 str(monitors), "--out", str(tmp_path / "set")]) == 2  # fmt: skip
    assert "has no luminance calibration in Monitor Center" in capsys.readouterr().err
    assert main(["stimuli", "build", "spencer1995", "--monitor-folder", str(monitors),
                 "--out", str(tmp_path / "set")]) == 2  # fmt: skip
    assert "--monitor-folder needs --monitor NAME" in capsys.readouterr().err


WINDOW = textwrap.dedent(
    """
    import sys
    from psychopy import logging
    from glarelab.frontend.monitors import load_monitor, window_monitor
    from glarelab.frontend.window import open_window
    from glarelab.protocols import load_protocol

    logging.console.setLevel(logging.WARNING)
    protocol = load_protocol("spencer1995")
    for monitor in (None, window_monitor(protocol["display"], protocol["viewing"]),
                    window_monitor(None, None, monitor=load_monitor("crt", folder=sys.argv[1]))):
        window, bits = open_window(bits=8, fullscreen=False, size=(64, 64), monitor=monitor)
        print("MONITOR", window.monitor.name, window.monitor.getWidth(),
              window.monitor.getDistance(), window.useNativeGamma, flush=True)
        window.close()
    """
)


def test_glarelab_windows_have_a_monitor_and_keep_the_gamma_table(tmp_path, spencer_calibration):
    monitors = tmp_path / "monitors"
    monitors.mkdir()
    assert main(["calibrate", "export-monitor", str(spencer_calibration), "--monitor", "crt",
                 "--protocol", "spencer1995", "--monitor-folder", str(monitors)]) == 0  # fmt: skip
    script = tmp_path / "window.py"
    script.write_text(WINDOW)
    x = XScreen(tmp_path)
    try:
        env = {**x.env, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")])}  # fmt: skip
        done = subprocess.run([sys.executable, str(script), str(monitors)], env=env,
                              capture_output=True, text=True, timeout=300, check=False)  # fmt: skip
    finally:
        x.close()
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Monitor specification not found" not in done.stderr + done.stdout
    lines = [line.split()[1:] for line in done.stdout.splitlines() if line.startswith("MONITOR")]
    assert [line[0] for line in lines] == ["glarelab", "glarelab", "crt"]
    assert lines[0][1:3] == ["None", "None"]  # no geometry asked for: none given
    assert float(lines[1][1]) == pytest.approx(WIDTH_CM) and lines[1][2] == "60.0"
    assert float(lines[2][1]) == pytest.approx(WIDTH_CM) and lines[2][2] == "60.0"
    # the monitor's gamma never reaches the card: PsychoPy keeps the system's gamma table
    assert [line[3] for line in lines] == ["True", "True", "True"]


def test_an_earlier_releases_export_is_renamed_to_sort_by_its_date(tmp_path, spencer_calibration):
    """Named 'glarelab 2026-12-03 HASH' by an earlier release, it sorted after every new
    export's dated name, and each new export was refused."""
    monitors = tmp_path / "monitors"
    monitors.mkdir()
    argv = ["calibrate", "export-monitor", str(spencer_calibration), "--monitor", "crt",
            "--monitor-folder", str(monitors)]  # fmt: skip
    assert main(argv) == 0
    saved = json.loads((monitors / "crt.json").read_text())
    ((name, content),) = saved.items()
    digest = name.split()[-1]
    (monitors / "crt.json").write_text(json.dumps({f"glarelab 2026-12-03 {digest}": content}))
    assert main(argv) == 0
    again = json.loads((monitors / "crt.json").read_text())
    first, second = sorted(again)
    assert first == f"2026_12_03 00:00:00.000000 glarelab {digest}" and again[first] == content
    from glarelab.frontend.monitors import load_monitor, monitor_display

    assert monitor_display(load_monitor("crt", folder=monitors))["calibration"] == second
