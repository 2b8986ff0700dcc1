"""The rating screens as a participant with a French keyboard sees and types them: real key
events through an X server whose layout is French AZERTY (setxkbmap fr), screenshots read back.

On AZERTY the unshifted number row makes ``& é " ' ( - è _ ç à``; Psychtoolbox names its keys
by position (``1`` … ``0``), so the rating is the key's position, and the comment is what the
layout typed, accents included, from the character after the rating key's own.
"""

import csv
import re
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from .xscreen import SCREEN, XScreen

CENTRE = (SCREEN[0] // 2, SCREEN[1] // 2)


@pytest.fixture
def french(tmp_path):
    x = XScreen(tmp_path, layout="fr")
    yield x
    x.close()


def rows_of(folder: Path) -> list[dict]:
    (path,) = sorted(Path(folder).glob("*.csv"))
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


def text_bands(image: np.ndarray) -> list[tuple[int, int]]:
    """The screen's lines of text: runs of pixel rows with anything lit."""
    lit = image.max(axis=(1, 2)) > 40
    bands, start = [], None
    for row, on in enumerate(lit):
        if on and start is None:
            start = row
        elif not on and start is not None:
            bands.append((start, row))
            start = None
    return bands


def test_french_keyboard_rates_by_key_position_and_keeps_every_accent(french, tmp_path):
    out = tmp_path / "data"
    french.run("run", "luidolt2020", "--participant", "P01", "--out", out)
    french.wait_for_log(out, r"session log")
    french.focus_window()
    time.sleep(0.3)
    french.key("space")
    french.wait_for_log(out, r"trial 1 onset")
    time.sleep(0.3)
    rate = french.screenshot()
    Image.fromarray(rate).save(tmp_path / "rate.png")
    # the question once: category, question, anchors, "Press a number key": four lines of text
    assert len(text_bands(rate)) == 4, text_bands(rate)
    # the unshifted 5 of AZERTY (it makes "("), then the comment typed at once, 30 ms a key,
    # before the comment box can have appeared
    french.key("parenleft")
    french.type("éèàçù, déjà vu (5 ç)")
    french.wait_for_log(out, r"screen comment of trial 1")
    time.sleep(0.3)
    comment = french.screenshot()
    Image.fromarray(comment).save(tmp_path / "comment.png")
    # the box (900 × 160 px, 40 px below the middle) holds the typed line and nothing else
    box = comment[
        CENTRE[1] - 40 + 4 : CENTRE[1] + 120 - 4, CENTRE[0] - 450 + 4 : CENTRE[0] + 450 - 4
    ]
    bands = text_bands(box)
    assert len(bands) == 1 and bands[0][0] < 40, bands  # the typed line, at the box's top
    french.key("Return")
    french.wait_for_log(out, r"trial 2 onset")
    french.key("KP_3")  # the keypad
    french.wait_for_log(out, r"screen comment of trial 2")
    french.type("ça été")
    french.key("Return")
    french.wait_for_log(out, r"trial 3 onset")
    french.key("7")  # Shift and the 7 key: the digit itself on AZERTY
    french.key("Return")
    french.wait_for_log(out, r"trial 4 onset")
    french.key("Escape")
    assert french.wait() == 3, french.stderr[-2000:]
    rows = rows_of(out)
    assert [(r["rating"], r["comment"]) for r in rows] == [
        ("5", "éèàçù, déjà vu (5 ç)"),
        ("3", "ça été"),
        ("7", ""),
    ]


def test_on_linux_keys_are_named_by_their_us_position_whatever_the_layout(tmp_path):
    """As the README says: on a German keyboard the key labelled Y is ``z`` (and Z is ``y``)."""
    german = XScreen(tmp_path, layout="de")
    try:
        out = tmp_path / "data"
        german.run("run", "luidolt2020", "--participant", "P01", "--out", out)
        german.wait_for_log(out, r"instructions screen onset")
        german.key("y")  # the key that types y in the German layout
        german.wait_for_log(out, r"key \w+ down")
        german.key("z")
        german.wait_for_log(out, r"key \w+ down", count=2)
        german.key("Escape")
        assert german.wait() == 3, german.stderr[-2000:]
        (log,) = out.glob("*.log")
        assert re.findall(r"key (\w+) down", log.read_text())[:2] == ["z", "y"]
    finally:
        german.close()


# dead keys: an accent key that types nothing, then the letter it goes on (real X key events)
DEAD_KEYS = {
    "fr": (
        ["dead_circumflex", "e", "t", "r", "e", "space", "dead_diaeresis", "i", "space",
         "dead_circumflex", "o", "dead_circumflex", "u", "space", "dead_circumflex", "space"],
        "être ï ôû ^",
    ),
    "de": (
        ["dead_acute", "e", "t", "dead_grave", "a", "space", "dead_circumflex", "e", "space",
         "dead_acute", "space"],
        "étà ê '",  # the Compose table: dead acute, then space, types an apostrophe
    ),
}  # fmt: skip


@pytest.mark.parametrize("fullscreen", [True, False], ids=["full screen", "windowed"])
@pytest.mark.parametrize("layout", ["fr", "de"])
def test_accents_typed_with_dead_keys_are_kept(tmp_path, layout, fullscreen):
    keys, typed = DEAD_KEYS[layout]
    x = XScreen(tmp_path, layout=layout)
    try:
        out = tmp_path / "data"
        x.run(
            "run", "luidolt2020", "--participant", "P01", "--out", out,
            *(["--fullscreen"] if fullscreen else []),
        )  # fmt: skip
        x.wait_for_log(out, r"session log")
        x.focus_window()
        time.sleep(0.3)
        x.key("space")
        x.wait_for_log(out, r"trial 1 onset")
        x.key("KP_4")
        x.wait_for_log(out, r"screen comment of trial 1")
        x.key(*keys, delay_ms=30)
        time.sleep(0.3)
        Image.fromarray(x.screenshot()).save(tmp_path / "comment.png")
        x.key("Return")
        x.wait_for_log(out, r"trial 2 onset")
        x.key("Escape")
        assert x.wait() == 3, x.stderr[-2000:]
    finally:
        x.close()
    assert [(r["rating"], r["comment"]) for r in rows_of(out)] == [("4", typed)]


LEGENDS = """
import json
from glarelab.experiments.matching import MatchingEngine
from glarelab.frontend.screens import ScreenText
from glarelab.frontend.window import key_labels, open_window
from glarelab.protocols import load_protocol

win, _ = open_window(bits=8, fullscreen=False, size=(1280, 800))
text = ScreenText(win, pilot=False)
engine = MatchingEngine(load_protocol("yoshida2008"), "P01")
instructions = {**engine.screen(), "legend": engine.key_legend()}
text.draw(instructions, [])
legend = text.text.text
engine.press("space")
engine.press("return")
text.draw({**engine.screen(), "images": []}, [])  # its text only
print("FOUND " + json.dumps({"legend": legend, "question": text.text.text,
                             "labels": key_labels(win, ["y", "n", "q", "a", "m", "5"])}))
win.close()
"""


@pytest.mark.parametrize(
    ("layout", "yes", "labels"),
    [
        ("us", "Y", {"y": "Y", "n": "N", "q": "Q", "a": "A", "m": "M", "5": "5"}),
        ("de", "Z", {"y": "Z", "n": "N", "q": "Q", "a": "A", "m": "M", "5": "5"}),
        ("fr", "Y", {"y": "Y", "n": "N", "q": "A", "a": "Q", "m": ",", "5": "("}),
    ],
)
def test_the_screens_name_the_keys_as_the_layout_labels_them(tmp_path, layout, yes, labels):
    import json
    import os
    import subprocess
    import sys

    x = XScreen(tmp_path, layout=layout)
    try:
        script = tmp_path / "legends.py"
        script.write_text(LEGENDS)
        done = subprocess.run(
            [sys.executable, str(script)],
            env={**x.env, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[2])])},
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
    finally:
        x.close()
    lines = [line for line in done.stdout.splitlines() if line.startswith("FOUND ")]
    assert lines, done.stderr[-3000:]
    found = json.loads(lines[0].removeprefix("FOUND "))
    assert found["labels"] == labels
    # a German participant is told the key that gives the session's "y": the one labelled Z
    assert f"{yes} = yes     N = no" in found["question"]
    assert f"{yes} / N: answer yes or no to the questions after each trial" in found["legend"]
