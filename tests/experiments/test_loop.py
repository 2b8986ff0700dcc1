"""The session loop against a scripted device: which presses count, how they are timed, and
what is recorded of the others."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from glarelab.experiments.engine import Press
from glarelab.experiments.loop import (
    SessionAborted,
    SessionLoop,
    Shown,
    count_dropped_frames,
    presentation_ok,
)
from glarelab.experiments.matching import MatchingEngine as BrightnessMatching
from glarelab.experiments.rating import RatingEngine as LikertQuestionnaire
from glarelab.experiments.staircase import StaircaseEngine as StaircaseExperiment
from glarelab.protocols import load_protocol


@pytest.fixture(scope="module")
def protocols():
    return {s: load_protocol(s) for s in ("yoshida2008", "spencer1995", "luidolt2020")}


class FakeDevice:
    """Shows screens at scripted times and hands out scripted presses in batches, as a
    keyboard buffer filled while the program was busy drawing would."""

    def __init__(self, batches, *, onset_step=1.0, flash=None):
        self.batches = list(batches)
        self.clock = 0.0
        self.onset_step = onset_step
        self.flash = flash or {}
        self.shown: list[tuple[str, float]] = []
        self.texts: list[str] = []

    def show(self, screen):
        self.clock += self.onset_step
        self.shown.append((screen["kind"], self.clock))
        return self.clock

    def present(self, screen):
        onset = self.clock + self.onset_step
        self.shown.append(("present", onset))
        dropped = self.flash.get(screen["trial"], 0)
        offset = onset + (screen["frames"] + dropped) / 76.0
        self.clock = offset
        return Shown(onset, offset, screen["frames"], dropped)

    def wait_keys(self, anchor_s):
        if not self.batches:
            return [Press("escape", self.clock)]
        batch = self.batches.pop(0)
        for press in batch:
            if len(press) > 2:  # the text typed before this Enter
                self.texts.append(press[2])
        return [Press(name, anchor_s + t) for name, t, *_ in batch]

    def typed(self):
        return self.texts.pop(0) if self.texts else ""


def run(engine, device, **options):
    rows = []
    loop = SessionLoop(device, rows.append, refresh_hz=76.0, **options)
    with pytest.raises(SessionAborted):
        loop.run(engine)
    return rows, loop


def test_presses_that_arrive_together_each_count_in_order(protocols):
    engine = BrightnessMatching(protocols["yoshida2008"], "P01")
    device = FakeDevice(
        [
            [("space", 0.5)],
            # ten ups, a switch and three downs, all read in one batch after a slow redraw
            [
                *[("up", 0.1 + 0.04 * i) for i in range(10)],
                ("right", 0.6),
                *[("down", 0.61), ("down", 0.62), ("down", 0.63)],
            ],
            [("return", 4.2)],
            [("y", 4.5), ("n", 4.6), ("y", 4.7)],
        ]
    )
    rows, _ = run(engine, device)
    (row,) = rows
    assert row["darker_cd_m2"] == 200.0 and row["brighter_cd_m2"] == 370.0
    assert row["adjustments"] == 13 and row["time_s"] == pytest.approx(4.2)
    assert row["onset_s"] == device.shown[1][1] and row["ignored_keys"] is None


def test_presses_before_the_onset_or_on_other_keys_are_recorded_not_taken(protocols):
    engine = StaircaseExperiment(protocols["spencer1995"], "P01", counterbalance=0, refresh_hz=76)
    device = FakeDevice(
        [
            [("space", 0.2)],
            [("left", -0.3), ("q", 0.1), ("right", 0.25)],  # early answer, a stray key, answer
            [("left", 0.2), ("left", 0.3)],  # a double press: the second is before trial 2
            [("down", 0.4)],
        ]
    )
    rows, loop = run(engine, device)
    assert [r["time_s"] for r in rows] == pytest.approx([0.25, 0.2, 0.4])
    assert rows[0]["ignored_keys"] == "left@-0.300;q@0.100"
    # the second press of trial 2 came after its answer: before trial 3's onset
    assert rows[1]["ignored_keys"] is None
    assert rows[2]["ignored_keys"].startswith("left@-") and loop.total_ignored == 3
    assert rows[0]["presentation_ok"] and rows[0]["counted"]


def test_a_flash_that_dropped_frames_is_flagged_and_repeated(protocols):
    engine = StaircaseExperiment(protocols["spencer1995"], "P01", counterbalance=0, refresh_hz=76)
    device = FakeDevice([[("space", 0.1)], [("left", 0.3)], [("left", 0.3)]], flash={1: 2})
    rows, _ = run(engine, device)
    failed, again = rows
    assert failed["dropped_frames"] == 2 and not failed["presentation_ok"]
    assert not failed["counted"] and not failed["reversal"]
    assert (again["glare_level"], again["disc_fraction"]) == (
        failed["glare_level"],
        failed["disc_fraction"],
    )
    assert again["counted"] and failed["shown_ms"] > again["shown_ms"]


def test_breaks_and_the_continue_screen(protocols):
    engine = LikertQuestionnaire(protocols["luidolt2020"], "P01")
    device = FakeDevice(
        [[("space", 0.1)]]
        + [[("4", 0.5)], [("return", 0.9)], [("space", 0.3)]] * 2  # each row, then a break
    )
    rows, _ = run(engine, device, break_every=1)
    assert len(rows) == 2
    assert [kind for kind, _ in device.shown].count("break") == 2
    resumed = LikertQuestionnaire(protocols["luidolt2020"], "P01")
    resumed.replay([{"trial": "1"}, {"trial": "2"}])
    device = FakeDevice([[("5", 0.3)], [("space", 0.5)], [("6", 0.5)], [("return", 0.5)]])
    rows = []
    with pytest.raises(SessionAborted):
        SessionLoop(device, rows.append, refresh_hz=60.0).run(resumed, resumed_after=2)
    # the "5" came before the continue screen was answered: not a rating
    assert device.shown[0][0] == "continue" and rows[0]["rating"] == 6
    assert rows[0]["trial"] == 3 and rows[0]["ignored_keys"].startswith("5@-")


def test_typed_text_comes_with_the_enter_that_ends_it(protocols):
    engine = LikertQuestionnaire(protocols["luidolt2020"], "P01")
    device = FakeDevice(
        [
            [("space", 0.1)],
            [("6", 1.0)],
            [("lshift", 1.2), ("t", 1.3)],  # keys typed into the text box: neither input...
            [("return", 2.0, "Too bright, isn't it.")],
        ]
    )
    rows, loop = run(engine, device)
    assert rows[0]["comment"] == "Too bright, isn't it." and rows[0]["rating"] == 6
    assert rows[0]["ignored_keys"] is None and loop.total_ignored == 0  # ...nor ignored


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(st.sampled_from(["up", "down", "pageup", "pagedown", "x"]), st.floats(0, 5)),
        max_size=40,
    ),
    st.integers(1, 8),
)
def test_no_press_is_lost_however_the_presses_are_batched(protocols, presses, batch):
    """Every press is either applied (a step of the target) or recorded as ignored."""
    presses = sorted(presses, key=lambda p: p[1])
    batches = [[("space", 0.1)]]
    batches += [presses[i : i + batch] for i in range(0, len(presses), batch)]
    batches += [[("return", 6.0)], [("y", 6.1), ("y", 6.2), ("y", 6.3)]]
    engine = BrightnessMatching(protocols["yoshida2008"], "P01")
    rows, _ = run(engine, FakeDevice(batches))
    (row,) = rows
    value = 100.0
    for name, _ in presses:
        step = {"up": 10.0, "down": -10.0, "pageup": 1.0, "pagedown": -1.0}.get(name, 0.0)
        value = min(max(value + step, 0.5), 433.0)
    assert row["darker_cd_m2"] == pytest.approx(value)
    ignored = [k for k in (row["ignored_keys"] or "").split(";") if k]
    assert len(ignored) == sum(name == "x" for name, _ in presses)


def test_dropped_frames_and_presentation_judgement():
    period = 1 / 76
    assert count_dropped_frames([k * period for k in range(31)], 76.0) == 0
    late = [0, period, 2 * period, 5 * period, 6 * period]  # three periods: two lost
    assert count_dropped_frames(late, 76.0) == 2
    assert count_dropped_frames([0.0, 1.45 * period], 76.0) == 0  # jitter is not a drop
    ok = Shown(0.0, 30 * period, 30, 0)
    assert presentation_ok(ok, refresh_hz=76.0, tolerance_ms=10.0)
    assert not presentation_ok(Shown(0.0, 30 * period, 30, 1), refresh_hz=76.0, tolerance_ms=10)
    slow = Shown(0.0, 30 * period + 0.011, 30, 0)
    assert not presentation_ok(slow, refresh_hz=76.0, tolerance_ms=10.0)


def test_keypad_keys_take_the_meaning_the_screen_uses(protocols):
    engine = BrightnessMatching(protocols["yoshida2008"], "P01")
    device = FakeDevice(
        [
            [("space", 0.1)],
            [("num_8", 0.5), ("num_9", 0.6), ("num_6", 0.7), ("num_2", 0.8), ("num_5", 0.9)],
            [("num_enter", 2.0)],
            [("y", 2.1), ("n", 2.2), ("y", 2.3)],
        ]
    )
    rows, _ = run(engine, device)
    (row,) = rows
    # Num Lock off: up (+10) and page up (+1) on the left, right, down (-10) on the right
    assert (row["darker_cd_m2"], row["brighter_cd_m2"]) == (111.0, 390.0)
    assert row["ignored_keys"] == "num_5@0.900"  # named as pressed, not as a digit
    rating = LikertQuestionnaire(protocols["luidolt2020"], "P01")
    rows, _ = run(rating, FakeDevice([[("space", 0.1)], [("num_6", 1.0)], [("num_enter", 1.5)]]))
    assert rows[0]["rating"] == 6  # Num Lock on: a digit


def test_a_display_that_keeps_failing_cannot_stall_the_staircase(protocols):
    engine = StaircaseExperiment(protocols["spencer1995"], "P01", counterbalance=0, refresh_hz=76)
    limit = protocols["spencer1995"]["trials"]["repeat_limit"]
    device = FakeDevice(
        [[("space", 0.1)]] + [[("left", 0.3)]] * (2 * limit + 2),
        flash={k: 1 for k in range(1, 100)},  # every flash drops a frame
    )
    rows, _ = run(engine, device)
    counted = [r["counted"] for r in rows]
    # shown again `limit` times, then the answer counts (still flagged)
    assert counted[: limit + 1] == [False] * limit + [True]
    assert not any(r["presentation_ok"] for r in rows)
    assert counted[limit + 1 : 2 * limit + 2] == [False] * limit + [True]
