"""Without PsychoPy's photometer plugins (an optional extra) the suite works, and asking for a
photometer names the package to install."""

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
