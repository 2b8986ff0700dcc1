"""write_exr and read_exr at their boundary: an image that cannot be written as it is (complex,
bool, masked, negative, non-finite, above float32's largest) is refused naming ``image``, and
what reading one part's pixels would drop (other parts, a pixel aspect ratio, a data window
inside a larger frame) is refused naming the file and the attribute."""

import math
import re

import numpy as np
import OpenEXR
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_array_equal

from glarelab.stimuli.exr import read_exr, write_exr

SETTINGS = settings(
    max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
FLOAT32_MAX = float(np.finfo(np.float32).max)


def _one_bad_pixel(spec) -> np.ndarray:
    value, row, col, rgb = spec
    image = np.full((4, 5, 3) if rgb else (4, 5), 100.0)
    image[row, col] = value
    return image


BAD_IMAGES = st.one_of(
    st.tuples(
        st.one_of(
            st.sampled_from([math.nan, math.inf, -math.inf, -1e-300]),
            st.floats(max_value=-1e-300),
            st.floats(min_value=FLOAT32_MAX * (1 + 1e-7), allow_infinity=False),
        ),
        st.integers(0, 3),
        st.integers(0, 4),
        st.booleans(),
    ).map(_one_bad_pixel),
    st.sampled_from(
        [
            np.ones((4, 4), complex),
            np.ones((4, 4), bool),
            np.full((4, 4), "1"),
            np.ma.masked_array(np.ones((4, 4)), mask=np.eye(4, dtype=bool)),
            np.ones(4),
            np.ones((4, 4, 2)),
            np.ones((0, 4)),  # no pixel
            np.ones((3, 0, 3)),
        ]
    ),
)


@SETTINGS
@given(image=BAD_IMAGES)
def test_a_bad_image_is_refused_naming_it_and_nothing_is_written(tmp_path, image):
    path = tmp_path / "bad.exr"
    with pytest.raises((ValueError, TypeError), match=r"^image must") as raised:
        write_exr(path, image)
    assert "\n" not in str(raised.value)
    assert not path.exists()


@pytest.mark.parametrize(
    ("image", "match"),
    [
        (
            np.full((2, 2), 1e40),
            r"image must be at most 3.4028235e\+38, float32's largest, .* 1e\+40 at index \(0, 0\)",
        ),
        (np.full((2, 2), -5.0), r"image must be >= 0 .*-5.0 at index \(0, 0\)"),
        (np.ones((2, 2), complex), r"image must hold real numbers .* got dtype complex128"),
    ],
)
def test_the_issue_cases_are_refused(tmp_path, image, match):
    with pytest.raises(ValueError, match=match):
        write_exr(tmp_path / "a.exr", image)


@SETTINGS
@given(
    values=st.lists(
        st.one_of(st.just(0.0), st.floats(0.0, FLOAT32_MAX)), min_size=12, max_size=12
    ),
    rgb=st.booleans(),
)
def test_every_writable_image_reads_back_as_written(tmp_path, values, rgb):
    image = np.array(values, dtype=np.float32).reshape((2, 2, 3) if rgb else (3, 4))
    path = write_exr(tmp_path / "good.exr", image)
    back = read_exr(path)
    assert_array_equal(back, image)
    assert np.isfinite(back).all()


HEADER = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
PIXELS = np.arange(24, dtype=np.float32).reshape(4, 6)


def _box(x0, y0, x1, y1):
    return (np.array([x0, y0], np.int32), np.array([x1, y1], np.int32))


def _write(path, header, channels=None):
    with OpenEXR.File(HEADER | header, channels or {"Y": PIXELS}) as exr:
        exr.write(str(path))
    return path


def test_a_data_window_inside_a_larger_frame_is_refused(tmp_path):
    path = _write(
        tmp_path / "window.exr",
        {"dataWindow": _box(10, 20, 15, 23), "displayWindow": _box(0, 0, 30, 30)},
    )
    with pytest.raises(
        ValueError, match=r"window.exr: dataWindow \(10, 20, 15, 23\) is not the displayWindow"
    ):
        read_exr(path)


def test_a_data_window_equal_to_its_display_window_is_read_whole_wherever_it_starts(tmp_path):
    box = _box(10, 20, 15, 23)
    path = _write(tmp_path / "offset.exr", {"dataWindow": box, "displayWindow": box})
    assert_array_equal(read_exr(path), PIXELS)


def test_a_pixel_aspect_ratio_other_than_one_is_refused(tmp_path):
    path = _write(tmp_path / "wide.exr", {"pixelAspectRatio": 2.0})
    with pytest.raises(
        ValueError, match=r"wide.exr: pixelAspectRatio is 2; glarelab needs square"
    ):
        read_exr(path)


def test_a_multi_part_file_is_refused_not_read_as_its_first_part(tmp_path):
    parts = [
        OpenEXR.Part(HEADER | {"name": name}, {"Y": PIXELS * k}, name)
        for k, name in ((1, "left"), (2, "right"))
    ]
    path = tmp_path / "stereo.exr"
    with OpenEXR.File(parts) as exr:
        exr.write(str(path))
    with pytest.raises(
        ValueError, match=r"stereo.exr: multi-part OpenEXR \(2 parts: 'left', 'right'\)"
    ):
        read_exr(path)


@pytest.mark.parametrize(
    ("name", "match"),
    [
        ("o.png", r"path must name an \.exr file \(OpenEXR is written\); got '.*o\.png'"),
        ("folder.exr", r"path '.*folder\.exr' is a folder; give the EXR file's name in it"),
    ],
)
def test_a_path_that_is_no_exr_file_is_refused(tmp_path, name, match):
    (tmp_path / "folder.exr").mkdir()
    with pytest.raises(ValueError, match=match):
        write_exr(tmp_path / name, np.ones((2, 2)))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["folder.exr"]


@pytest.mark.parametrize(
    ("path", "match"),
    [
        ("", r"^path must name an \.exr file; got ''$"),
        (None, r"^path must name an \.exr file; got None$"),
        (b"x.exr", r"^path must name an \.exr file; got b'x\.exr'$"),
        ("a" * 300 + ".exr", r"^path's file name is 304 bytes long; file systems allow 255"),
    ],
)
def test_a_path_that_cannot_be_a_file_name_is_refused_before_writing(
    tmp_path, monkeypatch, path, match
):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match=match):
        write_exr(path, np.ones((2, 2)))
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("image", ["a string", None, [[1.0, 2.0], [3.0]]])
def test_an_image_that_is_no_array_is_refused_naming_image(tmp_path, image):
    with pytest.raises(ValueError, match=r"^image must be an \(H, W\) or \(H, W, 3\) array"):
        write_exr(tmp_path / "o.exr", image)


def test_a_damaged_chunk_is_refused_not_read_as_nan(tmp_path):
    image = np.random.default_rng(0).uniform(0, 1, (64, 64))
    data = bytearray(write_exr(tmp_path / "good.exr", image).read_bytes())
    data[-50:-40] = b"\xff" * 10  # inside the last ZIP chunk: OpenEXR decodes NaN, no error
    (tmp_path / "bad.exr").write_bytes(bytes(data))
    with pytest.raises(ValueError, match=r"bad\.exr holds NaN or Inf \(damaged, or not a lum"):
        read_exr(tmp_path / "bad.exr")


def test_a_damaged_chunk_table_is_one_line_naming_the_file(tmp_path, capfd):
    """A tiled file whose chunk table OpenEXR cannot rebuild printed thirty lines of the
    library's errors, then 'Invalid part index '0': file has 0 parts.', naming no file."""
    import Imath

    header = OpenEXR.Header(50, 40)
    header["channels"] = {"Y": Imath.Channel(Imath.PixelType(Imath.PixelType.FLOAT))}
    header["tiles"] = Imath.TileDescription(
        16,
        16,
        Imath.LevelMode(Imath.LevelMode.ONE_LEVEL),
        Imath.LevelRoundingMode(Imath.LevelRoundingMode.ROUND_DOWN),
    )
    tiled = OpenEXR.OutputFile(str(tmp_path / "tiled.exr"), header)
    tiled.writePixels({"Y": np.full((40, 50), 100.0, np.float32).tobytes()})
    tiled.close()
    capfd.readouterr()
    with pytest.raises(ValueError, match=r"tiled\.exr cannot be read as OpenEXR \(truncated or "
                       r"damaged\?\): no part of it could be read; OpenEXR: .*chunk table"):  # fmt: skip
        read_exr(tmp_path / "tiled.exr")
    assert capfd.readouterr() == ("", "")  # the library's lines are in the message, once
    import os

    os.write(2, b"after\n")  # the descriptor is the process's own again
    assert capfd.readouterr().err == "after\n"
    assert read_exr(write_exr(tmp_path / "good.exr", np.ones((3, 4)))).shape == (3, 4)


def test_a_pipe_or_a_folder_is_named_as_what_it_is_not_as_no_such_file(tmp_path):
    """A named pipe given as an EXR (a background, an input) was 'no EXR file at ...'."""
    import os

    from glarelab.stimuli.exr import read_exr

    os.mkfifo(tmp_path / "pipe.exr")
    (tmp_path / "folder.exr").mkdir()
    with pytest.raises(ValueError, match=r"pipe\.exr: a named pipe \(FIFO\), not a regular"):
        read_exr(tmp_path / "pipe.exr")
    with pytest.raises(IsADirectoryError, match=r"folder\.exr: a folder, not a file"):
        read_exr(tmp_path / "folder.exr")
    with pytest.raises(FileNotFoundError, match=r"^no EXR file at .*none\.exr"):
        read_exr(tmp_path / "none.exr")


def test_a_negative_value_read_from_a_foreign_or_damaged_file_is_refused(tmp_path):
    # another tool writes what write_exr refuses; a damaged uncompressed chunk reads as any value
    values = np.full((8, 8), 5.0, np.float32)
    values[3, 4] = -8.3
    header = {"compression": OpenEXR.NO_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"Y": values}) as exr:
        exr.write(str(tmp_path / "negative.exr"))
    with pytest.raises(ValueError, match=r"holds a negative value.*-8\.3.* at index \(3, 4\)"):
        read_exr(tmp_path / "negative.exr")


@pytest.mark.parametrize(("channels", "sampled"), [("Y", "Y"), ("RGB", "B")])
def test_a_subsampled_channel_is_refused_not_read_as_a_smaller_image(channels, sampled, tmp_path):
    """A Y channel stored 2 × 2 subsampled was read as a half-size image, and render wrote a
    40 × 30 output for an 80 × 60 input, at another angular scale; a subsampled B gave numpy's
    "all input arrays must have the same shape", naming neither file nor channel."""
    import Imath

    full = Imath.PixelType(Imath.PixelType.FLOAT)
    image = np.full((60, 80), 50.0, np.float32)
    header = OpenEXR.Header(80, 60)
    header["channels"] = {
        c: Imath.Channel(full, 2, 2) if c == sampled else Imath.Channel(full) for c in channels
    }
    path = tmp_path / "sub.exr"
    out = OpenEXR.OutputFile(str(path), header)
    out.writePixels(
        {c: (image[::2, ::2] if c == sampled else image).copy().tobytes() for c in channels}
    )
    out.close()
    with pytest.raises(ValueError, match=rf"^{re.escape(str(path))}: channel {sampled} is "
                       r"subsampled \(2 × 2 pixels per sample"):  # fmt: skip
        read_exr(path)
