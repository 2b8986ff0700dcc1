"""``glarelab run`` without ``--participant`` asks in PsychoPy's (Qt's) dialog; with a
``DISPLAY`` whose X server does not answer, Qt would abort the process: the command refuses
first, naming the display and ``--participant``."""

from __future__ import annotations

import sys
import types

import pytest

import glarelab.experiments.session  # noqa: F401  - what run imports, as the other tests do
from glarelab.cli import main


def test_no_participant_and_a_dead_display_is_refused_before_qt(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("DISPLAY", ":9876")  # no X server there
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    # were the dialog opened, Qt would abort this process: a stand-in fails the test instead
    gui = types.ModuleType("psychopy.gui")
    gui.Dlg = lambda *args, **kwargs: pytest.fail("the dialog was opened on a dead display")
    monkeypatch.setitem(sys.modules, "psychopy.gui", gui)
    if "psychopy" in sys.modules:
        monkeypatch.setattr(sys.modules["psychopy"], "gui", gui, raising=False)
    status = main(["run", "yoshida2008", "--out", str(tmp_path / "runs")])
    err = capsys.readouterr().err
    assert status == 2, err
    assert "--participant is required: no display answers at DISPLAY=':9876'" in err, err
    assert "Traceback" not in err and not (tmp_path / "runs").exists()


def test_the_dialog_starts_from_sex_and_vision_given_on_the_command_line(monkeypatch):
    """--sex f --vision glasses without --participant: the dialog started both empty and the
    sidecar recorded None for each, the options dropped without a word."""
    import argparse

    from glarelab.frontend import dialog

    shown = {}

    class Dlg:
        OK = True

        def __init__(self, title):
            self.fields = {}

        def addText(self, *args, **kwargs):
            return types.SimpleNamespace(setWordWrap=lambda wrap: None)

        def addField(self, key, initial="", choices=None):
            self.fields[key] = initial

        def show(self):
            shown.update(self.fields)
            return {**self.fields, "participant": "P01"}

    gui = types.ModuleType("psychopy.gui")
    gui.Dlg = Dlg
    monkeypatch.setitem(sys.modules, "psychopy.gui", gui)
    if "psychopy" in sys.modules:
        monkeypatch.setattr(sys.modules["psychopy"], "gui", gui, raising=False)
    monkeypatch.setattr(dialog, "x_display_answers", lambda: True)
    monkeypatch.setattr(dialog, "qt_dialog_available", lambda: True)
    monkeypatch.setenv("DISPLAY", ":0")
    args = argparse.Namespace(
        title="run", session=1, age=41, sex="f", vision="glasses", participant=None
    )
    dialog.experiment_info(args, check_age=int, vision=("none", "glasses"))
    assert (shown["sex"], shown["vision"], shown["age"]) == ("f", "glasses", "41")
    assert (args.participant, args.sex, args.vision, args.age) == ("P01", "f", "glasses", 41)
