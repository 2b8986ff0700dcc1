"""``check_display`` refuses a calibration of another display before its window opens."""

from __future__ import annotations

from pathlib import Path

import pytest

import glarelab.frontend.check_display as check_display_module
from glarelab.display.calibration import Calibration, synthetic_calibration
from glarelab.frontend.check_display import check_display
from glarelab.protocols import load_protocol

CALIBRATIONS = Path(__file__).parents[2] / "calibrations"


class WindowOpened(Exception):
    """The check got as far as its window."""


@pytest.fixture
def no_window(monkeypatch):
    def opened(*args, **kwargs):
        raise WindowOpened

    monkeypatch.setattr(check_display_module, "PsychoPyFrontend", opened)


def test_a_calibration_of_another_display_is_refused_before_the_window(no_window):
    """The 8-bit 50 cd/m² display's calibration was taken for yoshida2008's 10-bit 433 cd/m²
    display without a word, the check recorded (and filed) under it."""
    yoshida = load_protocol("yoshida2008")
    spencer = Calibration.load(CALIBRATIONS / "SYNTHETIC-spencer1995-50cd-8bit.json")
    with pytest.raises(ValueError, match=r"the calibration is for a 8-bit display, the "
                       r"protocol's display is 10-bit: the check would be recorded under that "
                       r"display's calibration, so no mismatch of bit depth can be accepted"):  # fmt: skip
        check_display(yoshida, calibration=spencer)
    with pytest.raises(ValueError, match="no mismatch of bit depth can be accepted"):
        check_display(yoshida, calibration=spencer, accept_mismatch=True)
    dim = synthetic_calibration(max_cd_m2=100.0, black_cd_m2=0.5, bit_depth=10)
    with pytest.raises(ValueError, match=r"not of the yoshida2008 protocol's display: it is a "
                       r"10-bit calibration with white 100 cd/m².*check anyway with "
                       r"--accept-mismatch calibration"):  # fmt: skip
        check_display(yoshida, calibration=dim)
    with pytest.raises(WindowOpened):  # knowingly: measured, the mismatch recorded
        check_display(yoshida, calibration=dim, accept_mismatch=True)
    own = Calibration.load(CALIBRATIONS / "SYNTHETIC-yoshida2008-433cd-10bit.json")
    with pytest.raises(WindowOpened):
        check_display(yoshida, calibration=own)


def test_a_stimulus_set_of_another_protocol_is_named_as_such(no_window):
    """A yoshida2008 set given to spencer1995's check was refused only with 'glare_none_07.exr
    is not in its manifest', a file the user never made."""
    from glarelab.stimuli.stimulus_set import cached_stimulus_set

    yoshida = cached_stimulus_set(load_protocol("yoshida2008"), progress=None)
    with pytest.raises(ValueError, match=r"the stimulus set .* was built from another protocol "
                       r"\(yoshida2008\)"):  # fmt: skip
        check_display(load_protocol("spencer1995"), stimuli=yoshida, frames=30)
    with pytest.raises(WindowOpened):  # its own protocol's
        check_display(load_protocol("yoshida2008"), stimuli=yoshida, frames=30)


def test_a_file_swapped_in_the_set_is_named_as_the_sets_not_the_screens(no_window, tmp_path):
    """One PNG copied over another was read back as '0.667 % exact, worst difference 201
    codes', a fault of the screen."""
    import shutil

    from glarelab.stimuli.stimulus_set import cached_stimulus_set

    protocol = load_protocol("yoshida2008")
    copy = tmp_path / "set"
    shutil.copytree(cached_stimulus_set(protocol, progress=None), copy)
    pngs = sorted(copy.glob("*_10bit.png"))
    shutil.copy(pngs[0], pngs[1])
    with pytest.raises(ValueError, match=rf"fails its manifest: .*{pngs[1].name}"):
        check_display(protocol, stimuli=copy, frames=30)
