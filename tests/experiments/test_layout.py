"""Whole-pixel layout (glarelab.experiments.layout): every edge of every image on a screen pixel
boundary, for odd and even images on odd and even windows; and what ``protocol check`` says of
a protocol's drawing."""

import itertools
import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from glarelab.cli import main
from glarelab.experiments.layout import row_layout

ROOT = Path(__file__).parents[2]

sizes = st.tuples(st.integers(1, 700), st.integers(1, 700))


@given(
    window=st.tuples(st.integers(1, 4096), st.integers(1, 2160)),
    images=st.lists(sizes, min_size=1, max_size=4),
    gap=st.integers(0, 200),
)
def test_every_edge_is_on_a_whole_pixel_and_the_row_is_centred(window, images, gap):
    placements = row_layout(window, images, gap_px=gap)
    for placement, (w, h) in zip(placements, images, strict=True):
        x, y = placement.pos  # PsychoPy's centre, from the window's centre
        # the edges PsychoPy draws (centre ± half the size), from the window's corner
        left, bottom = x - w / 2 + window[0] / 2, y - h / 2 + window[1] / 2
        assert left == placement.left_px and bottom == placement.bottom_px
        assert float(left).is_integer() and float(bottom).is_integer()
        assert abs(bottom + h / 2 - window[1] / 2) <= 0.5  # centred within half a pixel
    for a, b in itertools.pairwise(placements):
        assert b.left_px - (a.left_px + a.width_px) == gap
    total = sum(w for w, _ in images) + gap * (len(images) - 1)
    assert abs(placements[0].left_px + total / 2 - window[0] / 2) <= 0.5
    fits = total <= window[0] and max(h for _, h in images) <= window[1]
    assert all(p.inside for p in placements) == fits


def test_yoshida_row_on_odd_and_even_windows():
    # 271-px images: at a whole-pixel centre of an even window their edges would be halves
    even = row_layout((1920, 1080), [(271, 271)] * 3, gap_px=34)
    assert [p.pos for p in even] == [(-305.5, -0.5), (-0.5, -0.5), (304.5, -0.5)]
    odd = row_layout((1919, 1079), [(271, 271)] * 3, gap_px=34)
    assert [p.pos for p in odd] == [(-305.0, 0.0), (0.0, 0.0), (305.0, 0.0)]
    spencer = row_layout((1280, 1024), [(300, 300)] * 2, gap_px=60)
    assert [p.pos for p in spencer] == [(-180.0, 0.0), (180.0, 0.0)]


@pytest.mark.parametrize(
    "window, images, gap, message",
    [
        ((1920.5, 1080), [(10, 10)], 0, "window_px must be a whole number of pixels"),
        ((1920, 1080), [(10.5, 10)], 0, "image width must be a whole number of pixels"),
        ((1920, 1080), [(10, 0)], 0, "image height must be a whole number of pixels, at least 1"),
        ((1920, 1080), [(10, 10)], -1, "gap_px must be a whole number of pixels, at least 0"),
        ((1920, 1080), [(10, 10)], True, "gap_px must be a whole number"),
    ],
)
def test_sizes_that_are_not_whole_pixels_are_refused(window, images, gap, message):
    with pytest.raises(ValueError, match=message):
        row_layout(window, images, gap_px=gap)


def test_protocol_check_says_how_each_study_is_drawn(capsys):
    assert main(["protocol", "check", "yoshida2008"]) == 0
    out = capsys.readouterr().out
    assert (
        "drawn 1:1 on the display's 2048 × 1536 px: 3 images of 271 × 271 px, 34 px apart; "
        "every edge on a whole pixel (left columns 583, 888, 1193); the row's centre is 0.5 px "
        "left of and 0.5 px below the screen's" in out
    )
    assert "stimulus.size_deg = 3.2 is 270.63 display pixels: rendered and drawn as 271 px" in out
    assert main(["protocol", "check", "spencer1995"]) == 0
    assert "2 images of 300 × 300 px, 60 px apart; every edge on a whole pixel" in (
        capsys.readouterr().out
    )
    assert main(["protocol", "check", "luidolt2020"]) == 0  # no images: nothing to draw
    assert "drawn" not in capsys.readouterr().out


def test_protocol_check_says_when_a_row_cannot_be_drawn_1_to_1(tmp_path, capsys):
    # 3 × 8.0654° fits the display's 2048 px in degrees (2046.3 px), but each image is an odd
    # number of whole pixels (683): 2049 px drawn
    text = (ROOT / "src" / "glarelab" / "protocols" / "yoshida2008.toml").read_text()
    text = text.replace("size_deg = 3.2 ", "size_deg = 8.0654 ").replace(
        "gap_deg = 0.4 ", "gap_deg = 0.0 "
    )
    path = tmp_path / "wide.toml"
    path.write_text(text)
    assert main(["protocol", "check", str(path)]) == 1
    out = capsys.readouterr().out
    assert (
        "CANNOT be drawn 1:1 on the display's 2048 × 1536 px: 3 images of 683 × 683 px, 0 px "
        "apart take 2049 × 683 px, more than the screen" in out
    )


def test_protocol_check_says_when_pixel_deg_is_not_the_displays(tmp_path, capsys):
    text = (ROOT / "src" / "glarelab" / "protocols" / "spencer1995.toml").read_text()
    assert "\npixel_deg" not in text
    text = text.replace("window_px = 300 ", "pixel_deg = 0.03\nwindow_px = 300 ")
    path = tmp_path / "spencer_pixel.toml"
    path.write_text(text)
    assert main(["protocol", "check", str(path)]) == 0
    out = capsys.readouterr().out
    display = math.degrees(math.atan(18.0 * 25.4 / math.hypot(1280, 1024) / 600.0))
    assert f"pixel_deg = 0.03° is not the display's pixel ({display:.4g}°" in out
    assert f"{100 * (0.03 / display - 1):+.1f} % off the protocol's" in out
