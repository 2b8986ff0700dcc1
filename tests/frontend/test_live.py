"""LiveView's loop without a screen: what it shows and for how long, on a clock of the test's."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from glarelab.frontend.live import LiveView
from glarelab.glare.rendering.display import CodeTable


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def getTime(self) -> float:  # PsychoPy's name
        return self.t


def _view(clock: Clock, first_render_s: float, render_s: float) -> LiveView:
    """A LiveView whose renderer takes ``first_render_s`` for its first frame (the bank being
    built) and ``render_s`` for each later one, and whose flips take no time."""
    view = object.__new__(LiveView)
    state = SimpleNamespace(
        gaze_x_px=5.0, gaze_y_px=5.0, pupil_mm=5.0, valid_gaze=True, valid_pupil=True,
        clamped=False,
    )  # fmt: skip
    rendered = []

    def frame(*, encode, **_):
        clock.t += render_s if rendered else first_render_s
        rendered.append(clock.t)
        image = np.zeros((4, 4), dtype=np.float32)
        return SimpleNamespace(
            image=image, codes=encode(image), render_ms=1.0, target_cd_m2=1.0,
            adaptation_cd_m2=1.0, new_entries=0,
        )  # fmt: skip

    view.filter = SimpleNamespace(update=lambda *a: state)
    view.live = SimpleNamespace(frame=frame)
    view.top = 255
    view.encode = CodeTable(np.linspace(0.0, 1.0, 256))
    view.levels = (np.arange(256) / 255).astype(np.float32)
    view.stim = SimpleNamespace(image=None, draw=lambda: None)
    view.window = SimpleNamespace(flip=lambda: clock.t)
    view.origin_px = (0.0, 0.0)
    view.frames = view.dropped = 0
    view.render_ms = []
    return view


def test_the_free_viewing_lasts_its_seconds_from_the_first_frame_shown():
    # a first frame that takes 3 s to render (the bank built on a loaded machine) used to
    # take the whole 1 s viewing: one frame shown, for one frame's time
    clock = Clock()
    view = _view(clock, first_render_s=3.0, render_s=0.02)
    source = SimpleNamespace(time_s=lambda: clock.t, sample=lambda: (5.0, 5.0, 5.0))
    flips = view.run(
        source, clock=clock, refresh_hz=50.0, write_row=lambda *a: None, stop=lambda: False,
        duration_s=1.0,
    )  # fmt: skip
    assert flips[0] == 3.0
    assert flips[-1] - flips[0] >= 1.0 - 1e-9
    assert view.frames == 51  # 1 s of 20 ms frames after the first
