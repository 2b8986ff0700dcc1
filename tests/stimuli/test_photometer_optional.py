"""Without PsychoPy's photometer plugins (an optional extra) the suite works, and asking for a
photometer names the package to install."""

import subprocess
import sys

import pytest

from glarelab.cli import main


@pytest.mark.parametrize(
    ("model", "module", "package"),
    [
        ("LS-100", "psychopy_minolta", "psychopy-minolta"),
        ("PR-655", "psychopy_photoresearch", "psychopy-photoresearch"),
        ("ColorCAL", "psychopy_crs", "psychopy-crs"),
    ],
)
def test_a_missing_plugin_is_named(tmp_path, monkeypatch, capsys, model, module, package):
    monkeypatch.setitem(sys.modules, module, None)  # as if not installed: import fails
    monkeypatch.delitem(sys.modules, f"{module}.colorcal", raising=False)
    out = str(tmp_path / "d.json")
    status = main(["calibrate", "measure", "--out", out, "--photometer", model, "--port", "x"])
    assert status == 2
    err = capsys.readouterr().err
    assert f"PsychoPy's {package} plugin, which is not installed" in err
    assert "pip install 'glarelab[photometer]'" in err
    assert not (tmp_path / "d.session.json").exists()


def test_the_measurement_modules_import_without_the_plugins():
    blocked = ["psychopy_minolta", "psychopy_photoresearch", "psychopy_crs", "serial"]
    script = (
        f"import sys; sys.modules.update(dict.fromkeys({blocked!r}))\n"
        "import stimuli.photometer, stimuli.measure, glarelab.commands.calibrate\n"
        "print(sorted(stimuli.photometer.PHOTOMETERS))"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == "['CS-100A', 'ColorCAL', 'LS-100', 'LS-110', 'PR-655']"
