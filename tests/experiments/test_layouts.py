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
