"""A file glarelab reads is a regular file, or the message says what is there instead; text is
UTF-8 or UTF-16/32 with its byte-order mark, any other encoding named by its first bad byte."""

from __future__ import annotations

import json
import os

import pytest

from glarelab.display.calibration import read_readings
from glarelab.files.inputs import input_file, loads_json, read_input_text
from glarelab.protocols import load_protocol

READINGS = "code,luminance_cd_m2\n0,0.42\n512,94.8\n1023,432.4\n"


@pytest.fixture
def specials(tmp_path):
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "folder").mkdir()
    (tmp_path / "loop").symlink_to(tmp_path / "loop")
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    return tmp_path


@pytest.mark.parametrize(
    ("name", "error", "says"),
    [
        ("fifo", ValueError, "a named pipe (FIFO), not a regular file"),
        ("folder", IsADirectoryError, "a folder, not a file"),
        ("loop", ValueError, "a loop of symbolic links, not a file"),
        ("dangling", FileNotFoundError, "no readings file at"),
        ("none", FileNotFoundError, "no readings file at"),
    ],
)
def test_what_is_not_a_regular_file_is_named(specials, name, error, says):
    with pytest.raises(error, match=r"readings file|no readings") as raised:
        read_readings(specials / name)  # a FIFO is never opened: this would wait for ever
    assert says in str(raised.value) and str(specials / name) in str(raised.value)


def test_dev_null_is_a_device():
    with pytest.raises(ValueError, match=r"^protocol file /dev/null: a device"):
        load_protocol("/dev/null")
    with pytest.raises(ValueError, match=r"^readings file /dev/null: a device"):
        input_file("/dev/null", what="readings file")


@pytest.mark.parametrize("encoding", ["utf-8", "utf-8-sig", "utf-16", "utf-16-be", "utf-32"])
def test_unicode_text_with_its_mark_is_read(tmp_path, encoding):
    path = tmp_path / "readings.csv"
    data = READINGS.encode(encoding)
    if encoding == "utf-16-be":  # Python writes no mark for an explicit byte order
        data = b"\xfe\xff" + data
    path.write_bytes(data)
    assert read_input_text(path, what="readings file") == READINGS
    assert read_readings(path) == [(0, 0.42), (512, 94.8), (1023, 432.4)]


def test_another_encoding_is_refused_by_its_byte(tmp_path):
    path = tmp_path / "readings.csv"
    path.write_bytes(b"code,luminance_cd_m2\n0,0.5\n1,\xb5\n")
    with pytest.raises(ValueError, match=r"readings\.csv: byte 29 is not UTF-8 text; save it"):
        read_readings(path)
    # a UTF-16 file without its mark is not guessed: its NUL bytes are named
    path.write_bytes(READINGS.encode("utf-16-le"))
    with pytest.raises(ValueError, match="byte 1 is a NUL: UTF-16 text without its"):
        read_readings(path)


@pytest.mark.parametrize("value", [None, 3, b"yoshida2008", ["yoshida2008"]])
def test_a_path_of_the_wrong_type_is_a_type_error_naming_the_argument(value):
    from glarelab.display.calibration import Calibration
    from glarelab.stimuli.stimulus_set import verify_stimulus_set

    for call, what in [
        (load_protocol, "protocol"),
        (read_readings, "readings file"),
        (Calibration.load, "calibration file"),
        (verify_stimulus_set, "stimulus set folder"),
    ]:
        with pytest.raises(TypeError, match=rf"^{what}: a path \(str or os.PathLike\) is needed"):
            call(value)


@pytest.mark.parametrize("value", [None, 3, "0,0.4", {0: 0.4}])
def test_readings_of_the_wrong_type_are_a_type_error(value):
    from glarelab.display.calibration import fit_calibration

    with pytest.raises(TypeError, match=r"^readings: readings must be a sequence of \(code"):
        fit_calibration(value, bit_depth=10)


@pytest.mark.parametrize("text", ["", "  "])
def test_an_empty_path_is_refused_not_read_as_the_working_folder(text):
    from glarelab.files.inputs import as_path

    with pytest.raises(ValueError, match=r"^protocol: the path is empty \(an unset shell var"):
        as_path(text, what="protocol")
    with pytest.raises(ValueError, match=r"^protocol: the path is empty"):
        load_protocol(text)


@pytest.mark.parametrize(
    "text", ["[" * 100000 + "]" * 100000, '{"a":' * 100000 + "1" + "}" * 100000]
)
def test_json_nested_too_deeply_is_invalid_json_naming_the_file(text):
    """json.loads raises RecursionError for such nesting, which every reader of a JSON file
    let through as a crash."""
    with pytest.raises(json.JSONDecodeError) as refused:
        loads_json(text, source="deep.json")
    assert str(refused.value) == (
        "deep.json: arrays or objects nested too deeply (glarelab's JSON files nest a few levels)"
    )
    with pytest.raises(ValueError, match=r"^arrays or objects nested too deeply"):
        loads_json(text.encode())
    assert loads_json('{"a": [[1]]}') == {"a": [[1]]}
