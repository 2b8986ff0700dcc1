import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_array_equal
from PIL import Image

from glarelab.protocols import load_protocol
from glarelab.stimuli.exr import read_exr
from glarelab.stimuli.stimulus_set import (
    build_stimulus_set,
    default_calibration,
    read_png_codes,
    verify_stimulus_set,
    write_codes,
    write_display_png,
)

PROTOCOLS = Path(__file__).parents[2] / "src" / "glarelab" / "protocols"


def build_in_process(study, out):
    command = [
        sys.executable,
        "-m",
        "glarelab",
        "stimuli",
        "build",
        study,
        "--out",
        str(out),
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    return done


@pytest.mark.parametrize("study", ["yoshida2008", "spencer1995"])
def test_builds_in_separate_processes_are_identical_and_verify(tmp_path, study):
    first = build_in_process(study, tmp_path / "a")
    build_in_process(study, tmp_path / "b")
    assert "[##############################]" in first.stderr  # the progress bar finished
    manifest_a = (tmp_path / "a" / "manifest.json").read_text()
    assert manifest_a == (tmp_path / "b" / "manifest.json").read_text()
    assert verify_stimulus_set(tmp_path / "a") == []
    manifest = json.loads(manifest_a)
    assert manifest["calibration"]["status"] == "synthetic"
    for name in manifest["files"]:
        assert (tmp_path / "a" / name).is_file()
    # one changed byte is found and named
    victim = sorted(n for n in manifest["files"] if n.endswith(".png"))[0]
    path = tmp_path / "a" / victim
    data = bytearray(path.read_bytes())
    data[-5] ^= 0xFF
    path.write_bytes(bytes(data))
    assert verify_stimulus_set(tmp_path / "a") == [
        f"{victim}: changed (sha256 differs from the manifest)"
    ]
    path.unlink()
    assert verify_stimulus_set(tmp_path / "a") == [f"{victim}: missing"]
    os.mkfifo(path)  # was named 'missing' though something is there
    assert verify_stimulus_set(tmp_path / "a") == [f"{victim}: a named pipe (FIFO), not the file"]
    path.unlink()
    command = [sys.executable, "-m", "glarelab", "stimuli", "verify", str(tmp_path / "a")]
    done = subprocess.run(command, capture_output=True, text=True, check=False)
    assert done.returncode == 1 and victim in done.stderr


def test_codes_decode_to_the_luminance_within_half_a_step(tmp_path):
    protocol = load_protocol(PROTOCOLS / "yoshida2008.toml")
    manifest = build_stimulus_set(protocol, tmp_path, progress=None)
    calibration = default_calibration(protocol)
    assert manifest["calibration"]["readings_sha256"] == calibration.readings_sha256
    for name in ("reference_vos_f", "target_start_brighter"):
        luminance = read_exr(tmp_path / f"{name}.exr").astype(float)
        codes, bits = read_png_codes(tmp_path / f"{name}_10bit.png")
        assert bits == 10 and codes.max() <= 1023
        # the file itself spans the 16-bit range, so a viewer shows the image, not black
        shown = np.asarray(Image.open(tmp_path / f"{name}_10bit.png"))
        assert shown.dtype == np.uint16
        assert_array_equal(shown >> 6, codes)  # the codes are the top 10 bits
        # NAME.png: the nearest 8-bit codes, which PsychoPy's ImageStim and viewers show
        eight = Image.open(tmp_path / f"{name}.png")
        assert eight.mode == "L"
        assert_array_equal(np.asarray(eight), np.rint(codes * 255 / 1023))
        assert manifest["images"][name]["files"] == [
            f"{name}.exr",
            f"{name}.png",
            f"{name}_10bit.png",
        ]
        decoded = calibration.decode(codes)
        step = calibration.step_cd_m2(codes)
        assert (np.abs(decoded - luminance) <= step / 2 + 1e-6).all()
    assert manifest["images"]["reference_vos_f"]["encoding"]["above_max"] == 0
    index = (tmp_path / "README.md").read_text()
    assert "README.md" in manifest["files"]  # hashed with the rest
    assert "value = round(code × 65535 / 1023)" in index and "sBIT" in index
    assert "SetImageStim" in index and "`NAME_10bit.png`" in index
    for name in manifest["images"]:
        assert f"`{name}.exr`" in index, name


@pytest.mark.parametrize("bits", [1, 8, 10, 12, 16])
def test_every_code_survives_the_png_and_fills_the_16_bit_range(tmp_path, bits):
    codes = np.arange(2**bits, dtype=np.uint16).reshape(1, -1)
    write_codes(tmp_path / "all.png", codes, bits)
    back, found = read_png_codes(tmp_path / "all.png")
    assert found == bits
    assert_array_equal(back, codes)
    shown = np.asarray(Image.open(tmp_path / "all.png")).astype(np.int64)
    assert shown[0, 0] == 0 and shown[0, -1] == 65535  # black and white, in any viewer
    assert_array_equal(shown >> (16 - bits), codes)  # an sBIT-aware reader's shift works too


@pytest.mark.parametrize("bits", [8, 10, 12, 16])
def test_every_code_of_every_channel_survives_a_colour_png(tmp_path, bits):
    # Pillow opens a 16-bit RGB PNG as 8-bit RGB: a colour set's codes need a decoder that
    # reads 16-bit samples (its top byte would give 3 where the file holds 734 at 10 bits)
    rng = np.random.default_rng(bits)
    every = np.arange(2**bits, dtype=np.uint16)
    codes = np.stack([every, rng.permutation(every), every[::-1]], axis=-1).reshape(1, -1, 3)
    write_codes(tmp_path / "colour.png", codes, bits)
    back, found = read_png_codes(tmp_path / "colour.png")
    assert found == bits and back.shape == codes.shape
    assert_array_equal(back, codes)
    cv2 = pytest.importorskip("cv2")  # another decoder reads the same samples
    values = cv2.imread(str(tmp_path / "colour.png"), cv2.IMREAD_UNCHANGED)[..., ::-1]
    assert_array_equal(np.rint(values * ((2**bits - 1) / 65535)), codes)


def test_an_8_bit_sets_pngs_are_8_bit_pngs_of_its_codes(tmp_path):
    # what PsychoPy's ImageStim draws as it is (Pillow's L, not I;16): the codes themselves
    protocol = load_protocol(PROTOCOLS / "spencer1995.toml")
    manifest = build_stimulus_set(protocol, tmp_path, progress=None)
    calibration = default_calibration(protocol)
    pngs = [f for f in manifest["files"] if f.endswith(".png") and f[0] in "cg"]
    assert len(pngs) == 26 and not [f for f in manifest["files"] if "bit.png" in f]
    for name in ("glare_lamp_05", "comparison_none_full"):
        image = Image.open(tmp_path / f"{name}.png")
        assert image.mode == "L"
        codes, _ = calibration.encode(read_exr(tmp_path / f"{name}.exr").astype(float))
        assert_array_equal(np.asarray(image), codes)
        assert_array_equal(read_png_codes(tmp_path / f"{name}.png")[0], codes)
        assert read_png_codes(tmp_path / f"{name}.png")[1] == 8
    index = (tmp_path / "README.md").read_text()
    assert "visual.ImageStim(win, image='NAME.png', units='pix')" in index
    # an image's files are named after it: a manifest pointing elsewhere is found
    data = json.loads((tmp_path / "manifest.json").read_text())
    data["images"]["glare_lamp_05"]["files"][1] = "glare_lamp_06.png"
    (tmp_path / "manifest.json").write_text(json.dumps(data))
    assert "manifest.json: image glare_lamp_05 points at glare_lamp_06.png (edited?)" in (
        verify_stimulus_set(tmp_path)
    )


@pytest.mark.parametrize("bits", [1, 8, 10, 12, 16])
def test_display_pngs_hold_the_nearest_8_bit_codes(tmp_path, bits):
    codes = np.arange(2**bits, dtype=np.int64).reshape(1, -1)
    write_display_png(tmp_path / "eight.png", codes, bits)
    shown = np.asarray(Image.open(tmp_path / "eight.png"))
    assert shown.dtype == np.uint8
    assert_array_equal(shown, np.floor(codes * 255 / (2**bits - 1) + 0.5))
    colour = np.stack([codes, codes[:, ::-1], codes], axis=-1)
    write_display_png(tmp_path / "colour.png", colour, bits)
    assert Image.open(tmp_path / "colour.png").mode == "RGB"
    with pytest.raises(
        ValueError, match=r"codes must be in \[0, 255\] for bit_depth 8; got 0-256"
    ):
        write_display_png(tmp_path / "x.png", np.array([[0, 256]]), 8)


def test_a_png_that_holds_no_codes_is_named(tmp_path):
    Image.new("RGBA", (4, 3)).save(tmp_path / "photo.png")  # with alpha: not a set's codes
    with pytest.raises(
        ValueError,
        match=r"photo.png: a set's codes are 8- or 16-bit greyscale or RGB; this PNG has 8-bit samples in 4 channel",
    ):
        read_png_codes(tmp_path / "photo.png")
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\nnonsense")
    with pytest.raises(ValueError, match=r"broken.png: not a PNG of display codes"):
        read_png_codes(tmp_path / "broken.png")


@settings(max_examples=40, deadline=None)
@given(
    bits=st.sampled_from([8, 10, 12]),
    seed=st.integers(0, 2**32 - 1),
    shape=st.tuples(st.integers(1, 9), st.integers(1, 9)),
)
def test_random_code_images_round_trip(tmp_path_factory, bits, seed, shape):
    rng = np.random.default_rng(seed)
    codes = rng.integers(0, 2**bits, size=shape).astype(np.uint16)
    codes.flat[0] = 2**bits - 1  # the extremes, wherever the draw fell
    codes.flat[-1] = 0
    path = tmp_path_factory.mktemp("png") / "codes.png"
    write_codes(path, codes, bits)
    back, found = read_png_codes(path)
    assert found == bits
    assert_array_equal(back, codes)


def test_codes_outside_the_bit_depth_are_refused(tmp_path):
    with pytest.raises(
        ValueError, match=r"codes must be in \[0, 255\] for bit_depth 8; got 0-256"
    ):
        write_codes(tmp_path / "x.png", np.array([[0, 256]]), 8)
    with pytest.raises(ValueError, match="bit_depth must be a whole number 1-16; got 17"):
        write_codes(tmp_path / "x.png", np.array([[0]]), 17)


@pytest.mark.parametrize("writer", [write_codes, write_display_png])
@pytest.mark.parametrize(
    ("codes", "bit_depth", "message"),
    [
        (np.array([1, 2, 3]), 10, r"codes must be an image, \(H, W\) greyscale or \(H, W, 3\) "
         r"RGB, of at least one pixel; got shape \(3,\)"),  # was a 3 × 1 column image
        (np.ones((2, 2, 4), int), 10, r"got shape \(2, 2, 4\)"),
        (np.zeros((0, 4), int), 10, r"got shape \(0, 4\)"),
        (np.ma.masked_array(np.ones((4, 4), int), mask=np.eye(4)), 10,
         "codes must be a plain array, not a masked array"),  # the mask was dropped
        (np.ones((2, 2), int), 10.0, "bit_depth must be a whole number 1-16; got 10.0"),
        (np.ones((2, 2), int), True, "bit_depth must be a whole number 1-16; got True"),
    ],
)  # fmt: skip
def test_codes_that_are_no_image_are_refused(writer, codes, bit_depth, message, tmp_path):
    with pytest.raises(ValueError, match=message):
        writer(tmp_path / "x.png", codes, bit_depth)
    assert not list(tmp_path.iterdir())


def test_a_calibration_for_another_bit_depth_is_refused(tmp_path):
    from glarelab.display.calibration import synthetic_calibration

    protocol = load_protocol(PROTOCOLS / "yoshida2008.toml")
    eight_bit = synthetic_calibration(max_cd_m2=433.0, black_cd_m2=0.5, bit_depth=8)
    with pytest.raises(ValueError, match="8-bit display, the protocol's display is 10-bit: "
                       "the set's images are that display's codes, so no mismatch of bit depth "
                       "can be accepted; calibrate"):  # fmt: skip
        build_stimulus_set(protocol, tmp_path, calibration=eight_bit, progress=None)
    with pytest.raises(ValueError, match="no mismatch of bit depth can be accepted"):
        build_stimulus_set(protocol, tmp_path, calibration=eight_bit, progress=None,
                           accept_mismatch=True)  # fmt: skip
    luidolt = load_protocol(PROTOCOLS / "luidolt2020.toml")
    with pytest.raises(ValueError, match="shows no images: there is no stimulus set to build"):
        build_stimulus_set(luidolt, tmp_path, progress=None)


def test_a_calibration_of_another_display_is_refused_at_build(tmp_path):
    from glarelab.cli import main
    from glarelab.display.calibration import synthetic_calibration

    protocol = load_protocol(PROTOCOLS / "yoshida2008.toml")  # a 433 cd/m² display
    dim = synthetic_calibration(max_cd_m2=100.0, black_cd_m2=0.5, bit_depth=10)
    with pytest.raises(
        ValueError,
        match=r"the calibration is not of the yoshida2008 protocol's display: it is a 10-bit calibration with white 100 cd/m²",
    ):
        build_stimulus_set(protocol, tmp_path / "set", calibration=dim, progress=None)
    assert not (tmp_path / "set").exists()
    dim.save(tmp_path / "dim.json")
    argv = ["stimuli", "build", "yoshida2008", "--out", str(tmp_path / "set"),
            "--calibration", str(tmp_path / "dim.json")]  # fmt: skip
    assert main(argv) == 2 and not (tmp_path / "set").exists()
    assert main([*argv, "--accept-mismatch", "calibration"]) == 0  # knowingly


def test_an_image_changed_while_the_set_is_in_use_is_refused(tmp_path):
    from glarelab.stimuli.stimulus_set import SetChanged, StimulusSet

    build_stimulus_set(load_protocol("spencer1995"), tmp_path, progress=None)
    held = StimulusSet(tmp_path)
    names = sorted(Path(n).stem for n in held.manifest["files"] if n.endswith(".exr"))
    first, later = names[0], names[-1]
    shown = held.image(first)
    # a rebuild with another calibration or geometry: a file replaced by other bytes
    (tmp_path / f"{later}.exr").write_bytes((tmp_path / f"{first}.exr").read_bytes())
    with pytest.raises(SetChanged, match=rf"{later}\.exr changed since the set was verified"):
        held.image(later)
    assert held.image(first) is shown  # what was read before the change is what was verified
    assert StimulusSet(tmp_path).manifest_sha256 == held.manifest_sha256


@pytest.mark.parametrize(
    ("codes", "match"),
    [
        (np.array([[0.0, np.nan]]), r"got nan at \(0, 1\)"),
        (np.array([[511.7, 3.0]]), r"got 511\.7 at \(0, 0\)"),
        (np.array([[True, False]]), r"got dtype bool"),
    ],
)
def test_codes_that_are_not_whole_numbers_are_refused_not_written(tmp_path, codes, match):
    """A NaN code was written as 0 (black), 511.7 as 512, without a word."""
    from glarelab.stimuli.stimulus_set import write_codes

    with pytest.raises(
        ValueError, match=rf"^codes must be whole numbers \(display codes\); {match}"
    ):
        write_codes(tmp_path / "c.png", codes, 10)
    assert not (tmp_path / "c.png").exists()
    write_codes(tmp_path / "c.png", np.array([[512.0, 3.0]]), 10)  # whole floats are codes


def test_a_manifest_nested_too_deeply_is_a_damaged_set_not_a_crash(tmp_path):
    """'{"a":' * 100000 as manifest.json stopped stimuli verify and run --stimuli with a
    RecursionError ('a bug in glarelab', exit 70)."""
    folder = tmp_path / "set"
    folder.mkdir()
    (folder / "manifest.json").write_text('{"a":' * 100000 + "1" + "}" * 100000)
    nested = "arrays or objects nested too deeply (glarelab's JSON files nest a few levels)"
    assert verify_stimulus_set(folder) == [
        f"{folder / 'manifest.json'}: not valid JSON ({nested})"
    ]
    glarelab = [sys.executable, "-m", "glarelab"]
    done = subprocess.run(
        [*glarelab, "stimuli", "verify", str(folder)], capture_output=True, text=True, check=False
    )
    assert done.returncode == 1 and nested in done.stderr and "Traceback" not in done.stderr
    done = subprocess.run(
        [*glarelab, "run", "yoshida2008", "--simulate", "--participants", "1", "--stimuli",
         str(folder), "--out", str(tmp_path / "data")],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 2 and nested in done.stderr
    assert len(done.stderr.strip().splitlines()) == 1
