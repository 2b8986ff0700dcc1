"""The night street, its sequences, and the stimulus set of a night rating study."""

import json
import tomllib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from PIL import Image

from glarelab.protocols import load_protocol, parse_protocol
from glarelab.stimuli.exr import read_exr
from glarelab.stimuli.night import (
    LAMP_RGB,
    POOL_FRACTION,
    WINDOW_FRACTION,
    night_plan,
    night_sequence,
    night_street,
    preview_strip,
)
from glarelab.stimuli.stimulus_set import (
    build_stimulus_set,
    shows_images,
    verify_stimulus_set,
    write_codes,
)
from tests.conftest import small_night_protocol


def street(**kwargs):
    options = {"pixel_deg": 0.1, "rng": np.random.default_rng(1)} | kwargs
    return night_street(options.pop("size_px", (80, 50)), **options)


def test_the_bulbs_are_at_the_lamp_luminance_and_the_rest_far_below():
    scene = street(lamp_cd_m2=2e4, size_px=(160, 100))
    img = scene["img"]
    for row, column in scene["lamps_px"]:  # the bulb's centre pixel is the bulb
        assert_allclose(img[int(row), int(column)], 2e4 * LAMP_RGB, rtol=1e-12)
    yy, xx = np.mgrid[0:100, 0:160]
    near = np.zeros((100, 160), bool)
    for row, column in scene["lamps_px"]:  # the bulbs: 0.25° across, here 1.25 px in radius
        near |= np.hypot(yy - row, xx - column) <= 2.0
    assert near.mean() < 0.01
    # the lit road and the lit windows (where a pool of light reaches a window, both)
    assert img[~near].max() <= 2e4 * (POOL_FRACTION + WINDOW_FRACTION) + 0.02


def test_the_poster_has_the_stripes_it_promises():
    scene = street(pixel_deg=0.02, size_px=(400, 300), ambient_cd_m2=0.05)
    row, column = (int(v) for v in scene["poster_px"])
    line = scene["img"][row, :, 1]
    left = line[column - 18 : column]  # 2 cycles/deg at 0.02°: 25 px a cycle
    assert left.max() > 3 * left.min()


@settings(max_examples=20, deadline=None)
@given(
    lamp=st.sampled_from([1.0, 1e4, 1e9]),
    ambient=st.sampled_from([0.0, 1e-6, 0.05, 1e3]),
    width=st.integers(16, 70),
    height=st.integers(16, 50),
    lamps=st.integers(1, 12),
    pixel=st.sampled_from([1e-3, 0.05, 1.0]),
)
def test_no_nan_and_no_negative_light_at_the_extremes(lamp, ambient, width, height, lamps, pixel):
    img = night_street(
        (width, height), pixel_deg=pixel, lamps=lamps, lamp_cd_m2=lamp, ambient_cd_m2=ambient,
        rng=np.random.default_rng(0),
    )["img"]  # fmt: skip
    assert img.shape == (height, width, 3)
    assert np.isfinite(img).all() and img.min() >= 0.0
    # a bulb, lit also by the other lamps' pools, or the poster
    assert img.max() <= max(lamp * (1 + lamps * POOL_FRACTION), 2 * ambient + 1e-3) * (1 + 1e-9)


def test_the_same_rng_gives_the_same_street():
    assert np.array_equal(street()["img"], street()["img"])


@pytest.mark.parametrize(
    ("kwargs", "pattern"),
    [
        ({"size_px": (8, 50)}, "size_px must be"),
        ({"size_px": (80,)}, "size_px must be"),
        ({"pixel_deg": 0.0}, "pixel_deg"),
        ({"lamps": 0}, "lamps must be"),
        ({"lamps": 2.5}, "lamps must be"),
        ({"lamp_cd_m2": -1.0}, "lamp_cd_m2"),
        ({"ambient_cd_m2": float("nan")}, "ambient_cd_m2"),
    ],
)
def test_bad_streets_are_refused_by_name(kwargs, pattern):
    with pytest.raises(ValueError, match=pattern):
        street(**kwargs)


def test_sequences():
    scene = street()
    still = night_sequence(scene, "still", seconds=2.0, frame_rate_hz=10.0)
    assert len(still["frames"]) == 1 and still["frame_time_s"] == 2.0
    dark = night_sequence(scene, "enter_dark", seconds=1.0, frame_rate_hz=10.0, start_cd_m2=50)
    assert len(dark["frames"]) == 10 and dark["initial_adaptation_cd_m2"] == 50.0
    gaze = night_sequence(scene, "gaze", seconds=1.0, frame_rate_hz=9.0)
    assert gaze["gaze_px"][4] == scene["lamps_px"][0]  # at the lamp half way
    assert gaze["gaze_px"][0] == gaze["gaze_px"][-1]  # and back
    single = night_sequence(scene, "gaze", seconds=0.05, frame_rate_hz=1.0)
    assert len(single["frames"]) == 1  # a single-frame sequence
    with pytest.raises(ValueError, match="sequence"):
        night_sequence(scene, "sunrise", seconds=1.0, frame_rate_hz=10.0)
    with pytest.raises(ValueError, match="seconds"):
        night_sequence(scene, "still", seconds=0.0, frame_rate_hz=10.0)


def test_a_preview_strip_shows_the_first_and_the_last_frame():
    frames = [np.full((10, 12, 3), v) for v in (0.0, 1.0, 2.0, 3.0, 4.0, 100.0)]
    strip = preview_strip(frames, l_dmax_cd_m2=100.0)
    assert strip.shape == (10, 4 * 12 + 3 * 4, 3) and strip.dtype == np.uint8
    assert strip[0, 0, 0] == 0 and strip[0, -1, 0] == 255


def test_rgb_codes_are_written_as_16_bit_png_scaled_with_sbit(tmp_path):
    cv2 = pytest.importorskip("cv2")
    codes = np.random.default_rng(0).integers(0, 1024, (7, 9, 3)).astype(np.uint16)
    codes[0, 0] = (0, 1, 1023)
    write_codes(tmp_path / "c.png", codes, 10)
    back = cv2.imread(str(tmp_path / "c.png"), cv2.IMREAD_UNCHANGED)[..., ::-1]
    assert back.dtype == np.uint16 and back[0, 0].tolist() == [0, 64, 65535]
    assert np.array_equal((back.astype(np.int64) * 1023 * 2 // 65535 + 1) // 2, codes)
    assert b"sBIT\n\n\n" in (tmp_path / "c.png").read_bytes()
    assert Image.open(tmp_path / "c.png").size == (9, 7)


def test_night2026_plan_shows_each_frame_for_whole_refreshes():
    protocol = load_protocol("night2026")
    plan = night_plan(protocol, 60.0)
    assert list(plan) == [c["name"] for c in protocol["conditions"]]
    assert plan["full"]["refreshes_per_frame"] == 6 and len(plan["full"]["frames"]) == 30
    assert night_plan(protocol, 144.0)["full"]["refreshes_per_frame"] == 14
    assert not shows_images(load_protocol("luidolt2020")) and shows_images(protocol)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    folder = tmp_path_factory.mktemp("night-set")
    protocol = parse_protocol(tomllib.loads(small_night_protocol()))
    manifest = build_stimulus_set(protocol, folder / "set", progress=None)
    return protocol, folder / "set", manifest


def test_the_set_holds_every_conditions_frames_as_float32_exr(built):
    protocol, folder, manifest = built
    assert verify_stimulus_set(folder) == []
    plan = manifest["parameters"]["sequences"]
    for condition in protocol["conditions"]:
        names = plan[condition["name"]]["frames"]
        assert len(names) == 3
        for name in names:
            record = manifest["images"][name]
            assert record["condition"] == condition["name"]
            assert record["effects"] == condition["effects"]
            frame = read_exr(folder / f"{name}.exr")
            assert frame.dtype == np.float32 and frame.shape == (48, 64, 3)
            assert np.isfinite(frame).all() and frame.min() >= 0.0
            assert frame.max() <= protocol["display"]["max_cd_m2"]
        assert f"preview_{condition['name']}.png" in manifest["files"]
    full = [manifest["images"][n] for n in plan["full"]["frames"]]
    adapting = [r["adaptation_cd_m2"] for r in full]
    assert adapting[0] > adapting[1] > adapting[2]  # entering the dark from 100 cd/m²
    assert full[0]["pupil_mm"] < full[2]["pupil_mm"]  # the pupil opens as the eye adapts
    no_glare = manifest["images"][plan["no_glare"]["frames"][0]]
    assert no_glare["pupil_mm"] is None


def test_each_condition_differs_from_the_full_pipeline(built):
    _, folder, manifest = built
    plan = manifest["parameters"]["sequences"]
    last = {c: read_exr(folder / f"{p['frames'][-1]}.exr") for c, p in plan.items()}
    for condition in ("no_glare", "no_acuity", "no_scotopic"):
        assert np.abs(last[condition] - last["full"]).max() > 1e-3, condition
    first = {c: read_exr(folder / f"{p['frames'][0]}.exr") for c, p in plan.items()}
    # without adaptation the eye is adapted at once: brighter in the first frame
    assert first["no_adaptation"].mean() > 2 * first["full"].mean()


def test_the_same_protocol_builds_identical_files(built, tmp_path):
    protocol, folder, manifest = built
    again = build_stimulus_set(protocol, tmp_path / "again", progress=None)
    assert again["files"] == manifest["files"]
    assert json.loads((folder / "manifest.json").read_text())["files"] == again["files"]


def test_a_single_frame_and_black_scene_build(tmp_path):
    protocol = parse_protocol(
        tomllib.loads(small_night_protocol(sequence="still", ambient_cd_m2=0.0, lamp_cd_m2=1e9))
    )
    manifest = build_stimulus_set(protocol, tmp_path / "set", progress=None)
    names = manifest["parameters"]["sequences"]["full"]["frames"]
    assert names == ["full_f000"]
    frame = read_exr(tmp_path / "set" / "full_f000.exr")
    assert np.isfinite(frame).all() and frame.min() >= 0.0


def test_the_adaptation_follows_the_gaze_and_a_still_is_one_frame(tmp_path):
    # 0.3° a pixel: the 5° window around the gaze sees the lamp's surroundings or the road
    gaze = parse_protocol(tomllib.loads(small_night_protocol(sequence="gaze", pixel_deg=0.3)))
    manifest = build_stimulus_set(gaze, tmp_path / "gaze", progress=None)
    frames = [manifest["images"][n] for n in manifest["parameters"]["sequences"]["full"]["frames"]]
    target = [f["target_cd_m2"] for f in frames]
    adapting = [f["adaptation_cd_m2"] for f in frames]
    # the log mean around the lamp is the dark sky and fronts around a small bulb: lower than
    # the lit road's; the eye moves part of the way there in one frame, and back
    assert target[1] < target[0] == target[2]
    assert target[1] < adapting[1] < adapting[0] == target[0]
    assert adapting[1] < adapting[2] < target[2]
    assert manifest["parameters"]["gaze_px"][1] == manifest["geometry"]["lamps_px"][0]
    still = parse_protocol(tomllib.loads(small_night_protocol(sequence="still")))
    plan = night_plan(still, 60.0)["full"]
    assert plan == {"frames": ["full_f000"], "refreshes_per_frame": 18, "refreshes": 18}


def test_the_set_rebuilds_to_its_own_manifest(built, tmp_path, monkeypatch):
    from glarelab.stimuli.stimulus_set import prove_stimulus_set

    _, folder, _ = built
    monkeypatch.setenv("GLARELAB_CACHE", str(tmp_path))  # nothing remembered: rebuilt
    assert prove_stimulus_set(folder) == []


@pytest.mark.parametrize("rng", [0, None, np.random.RandomState(0)])
def test_a_street_drawn_without_a_generator_is_refused_naming_rng(rng):
    message = r"^rng must be a numpy.random.Generator \(np.random.default_rng\(seed\)\); got"
    with pytest.raises(ValueError, match=message):
        night_street((64, 48), pixel_deg=0.1, rng=rng)


@pytest.mark.parametrize("street", [{}, {"img": np.zeros((4, 4, 3))}, None, "street"])
def test_a_sequence_of_what_is_not_a_street_is_refused_naming_street(street):
    with pytest.raises(ValueError, match=r"^street must be a night_street\(\) scene"):
        night_sequence(street, "gaze", seconds=1.0, frame_rate_hz=4.0)


@pytest.mark.parametrize("frames", [[], (), None])
def test_a_strip_of_no_frames_is_refused_naming_frames(frames):
    with pytest.raises(ValueError, match=r"^frames must be a non-empty list"):
        preview_strip(frames, l_dmax_cd_m2=100.0)
