"""What the participant sees is the stimulus set, code for code: every image of each shipped
study's set (the matching references and targets, the staircase's glare and comparison images,
every colour frame of the night study's scenes), shown by the session's own front-end in a real
PsychoPy window on an X server of 8 and 10 bits per channel, full screen and windowed, the way a
session shows it (``show`` for a matching trial, ``present`` for a flash and for a scene's
sequence), and read back from the X server while it is on the screen.

The proof owes nothing to glarelab: the screen is read by python-xlib from the X server's root
window (:meth:`tests.experiments.xscreen.XScreen.codes`, the pixels as shown, at the screen's
depth), the expected codes are the set's PNGs decoded by OpenCV, and the images are found where
they landed (the best whole-pixel offset near the centred row), so neither the front-end's
layout, its frame-buffer read nor its PNG decoder is taken on trust.
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import cv2
import numpy as np
import pytest

from .xscreen import XScreen

ROOT = Path(__file__).parents[2]
STUDIES = ("yoshida2008", "glare_methods2026", "spencer1995", "night2026")

# runs on the X screen: shows each screen as a session does and, after each flip that shows a
# set image, says which images and waits until the test has read the screen
SCRIPT = textwrap.dedent(
    """
    import json, sys
    from pathlib import Path

    from glarelab.frontend.session import PsychoPyFrontend
    from glarelab.protocols import load_protocol

    def screens(manifest):
        kinds = {name: r["kind"] for name, r in manifest["images"].items()}
        one = lambda role, name: {"role": role, "terms": [(name, 1.0)]}
        if manifest["paradigm"] == "matching":
            for name in sorted(n for n, k in kinds.items() if k == "reference"):
                yield "show", {"kind": "adjust", "trial": 1, "images": [
                    one("left", "target_start_darker"), one("reference", name),
                    one("right", "target_start_brighter")],
                    "labels": {"left": "darker", "right": "brighter"}, "marker": "left",
                    "keys": {}}
        elif manifest["paradigm"] == "staircase":
            glare = sorted(n for n, k in kinds.items() if k == "glare")
            for i, name in enumerate(glare):
                context = manifest["images"][name]["context"]
                pair = [one("glare", name), one("comparison", f"comparison_{context}_full")]
                yield "present", {"kind": "present", "trial": i + 1,
                                  "images": pair[:: 1 if i % 2 else -1], "frames": 2,
                                  "blank_before_ms": 0.0, "prompt": "Which disc?", "keys": {}}
        else:  # a scene's sequence, frame by frame, as a night session presents it (one
            # refresh a frame here: the test reads the screen after each frame's first flip)
            for condition, plan in sorted(manifest["parameters"]["sequences"].items()):
                steps = [{"images": [one("scene", name)], "frames": 1} for name in plan["frames"]]
                yield "present", {"kind": "present", "trial": 1, "condition": condition,
                                  "sequence": steps, "images": steps[0]["images"],
                                  "frames": sum(s["frames"] for s in steps),
                                  "blank_before_ms": 0.0, "prompt": "", "keys": {}}

    def checked_flips(how, screen):
        # the flips after which set images are on the screen, and the images each shows
        if how == "show":
            return {0: screen["images"]}
        steps = screen.get("sequence") or [{"images": screen["images"],
                                            "frames": screen["frames"]}]
        flips, flip = {}, 1  # flip 0 is the blank
        for step in steps:
            flips[flip] = step["images"]
            flip += step["frames"]
        return flips

    for study, folder in json.loads(sys.argv[1]).items():
        manifest = json.loads((Path(folder) / "manifest.json").read_text())
        for fullscreen in (True, False):
            device = PsychoPyFrontend(load_protocol(study), stimuli=folder,
                                      fullscreen=fullscreen, scripted_keys=[])
            facts = device.open()
            window = device.window
            flip, count, wanted = window.flip, [0], {}

            def flip_then_wait(*args, **kwargs):
                shown = flip(*args, **kwargs)
                images = wanted.get(count[0])
                count[0] += 1
                if images is not None:
                    left, top = (0, 0) if fullscreen else window.winHandle.get_location()
                    print("SHOWN " + json.dumps({
                        "study": study, "fullscreen": fullscreen,
                        "bits": int(facts.bits_per_channel),
                        "window": [int(v) for v in window.size],
                        "origin": [int(left), int(top)],
                        "names": [image["terms"][0][0] for image in images]}), flush=True)
                    assert sys.stdin.readline().strip() == "next"
                return shown

            window.flip = flip_then_wait
            try:
                for how, screen in screens(manifest):
                    count[0], wanted = 0, checked_flips(how, screen)
                    getattr(device, how)(screen)
            finally:
                device.close()
    print("DONE", flush=True)
    """
)


def codes_file(folder: Path, name: str, set_bits: int) -> Path:
    """The file of a set's image that holds its codes exactly (the set's README says which):
    ``NAME.png`` for an 8-bit display, ``NAME_<bits>bit.png`` for a deeper one."""
    return folder / (f"{name}.png" if set_bits == 8 else f"{name}_{set_bits}bit.png")


def png_codes(path: Path, set_bits: int, window_bits: int) -> np.ndarray:
    """The PNG's codes as OpenCV decodes the file, at the window's bits, (H, W, 3) RGB: an 8-bit
    PNG's samples are the codes; a 16-bit one's are scaled to the full 16-bit range."""
    values = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert values is not None and values.dtype in (np.uint8, np.uint16), path
    if values.ndim == 3:
        values = values[..., ::-1]  # OpenCV gives BGR
    else:
        values = np.repeat(values[..., None], 3, axis=-1)
    full = 255 if values.dtype == np.uint8 else 65535
    codes = np.rint(values.astype(np.float64) * (2**set_bits - 1) / full)
    return np.rint(codes * (2**window_bits - 1) / (2**set_bits - 1)).astype(np.int64)


def find(band: np.ndarray, band_left: int, band_top: int, expected, left: float, top: float):
    """The best whole-pixel offset of ``expected`` in ``band`` near its nominal (possibly
    half-pixel) top-left corner, the nearest first: (exact fraction, worst difference,
    [rows, columns] off)."""
    height, width = expected.shape[:2]
    best = (-1.0, None, None)
    offsets = sorted(
        (
            (x, y)
            for x in range(int(np.floor(left)) - 1, int(np.ceil(left)) + 2)
            for y in range(int(np.floor(top)) - 1, int(np.ceil(top)) + 2)
        ),
        key=lambda xy: abs(xy[0] - left) + abs(xy[1] - top),
    )
    for x, y in offsets:
        row, column = y - band_top, x - band_left
        if min(row, column) < 0 or column + width > band.shape[1] or row + height > band.shape[0]:
            continue
        shown = band[row : row + height, column : column + width]
        equal = np.all(shown == expected, axis=-1)
        if equal.mean() > best[0]:
            lines = [int(np.sum(~equal.all(axis=1))), int(np.sum(~equal.all(axis=0)))]
            best = (float(equal.mean()), int(np.abs(shown - expected).max()), lines)
        if best[0] == 1.0:
            break
    return best


@pytest.fixture(scope="module")
def study_sets():
    from glarelab.protocols import load_protocol
    from glarelab.stimuli.stimulus_set import cached_stimulus_set

    return {
        study: str(cached_stimulus_set(load_protocol(study), progress=None)) for study in STUDIES
    }


def read_back(tmp_path: Path, depth: int, sets: dict) -> list[dict]:
    """Every set image shown by the session's front-end, read back from the X server."""
    script = tmp_path / "show.py"
    script.write_text(SCRIPT)
    x = XScreen(tmp_path, depth=depth)
    results: list[dict] = []
    cache: dict = {}
    try:
        env = {
            **x.env,
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        }
        stderr = (tmp_path / "show.stderr").open("w")
        process = subprocess.Popen(
            [sys.executable, str(script), json.dumps(sets)],
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=stderr,
            text=True,
        )
        for line in process.stdout:
            if not line.startswith("SHOWN "):
                if line.startswith("DONE"):
                    break
                continue
            shown = json.loads(line.removeprefix("SHOWN "))
            results += compare(x, shown, sets, cache)
            process.stdin.write("next\n")
            process.stdin.flush()
        process.wait(timeout=120)
        stderr.close()
    finally:
        x.close()
    log = (tmp_path / "show.stderr").read_text()
    assert process.returncode == 0, f"the front-end failed:\n{log[-4000:]}"
    (tmp_path / "results.json").write_text(json.dumps(results))
    return results


def compare(x: XScreen, shown: dict, sets: dict, cache: dict) -> list[dict]:
    """The images of one flip, found on the X screen and compared with their PNGs."""
    folder = Path(sets[shown["study"]])
    if folder not in cache:
        cache[folder] = json.loads((folder / "manifest.json").read_text())
    manifest = cache[folder]
    set_bits, bits = manifest["calibration"]["bit_depth"], shown["bits"]
    expected = [png_codes(codes_file(folder, n, set_bits), set_bits, bits) for n in shown["names"]]
    width, height = shown["window"]
    left_edge, top_edge = shown["origin"]
    gap = manifest["geometry"]["gap_px"]
    sizes = [e.shape[1] for e in expected]
    left = (width - sum(sizes) - gap * (len(sizes) - 1)) / 2
    tallest = max(e.shape[0] for e in expected)
    band_left, band_top = max(int(left) - 2, 0), max(int((height - tallest) // 2) - 2, 0)
    band_width = min(int(np.ceil(width - 2 * left)) + 4, width - band_left)
    band_height = min(tallest + 4, height - band_top)
    band = x.codes((left_edge + band_left, top_edge + band_top, band_width, band_height))
    found = []
    for name, codes in zip(shown["names"], expected, strict=True):
        exact, worst, lines = find(
            band, band_left, band_top, codes, left, (height - codes.shape[0]) / 2
        )
        left += codes.shape[1] + gap
        found.append(
            {
                "study": shown["study"],
                "fullscreen": shown["fullscreen"],
                "bits": bits,
                "window": shown["window"],
                "image": name,
                "colour": manifest["images"][name]["shape"][2:] == [3],
                "exact": exact,
                "worst": worst,
                "rows_cols_off": lines,
            }
        )
    return found


@pytest.mark.parametrize("depth, bits", [(24, 8), (30, 10)])
def test_every_image_of_every_study_is_on_the_screen_code_for_code(
    tmp_path, study_sets, depth, bits
):
    results = read_back(tmp_path, depth, study_sets)
    assert {r["bits"] for r in results} == {bits}  # the window has the screen's bits
    for study, folder in study_sets.items():
        manifest = json.loads((Path(folder) / "manifest.json").read_text())
        with_png = {n for n, r in manifest["images"].items() if r["kind"] != "component"}
        for fullscreen in (True, False):
            shown = {
                r["image"]
                for r in results
                if r["study"] == study and r["fullscreen"] == fullscreen
            }
            assert shown == with_png, (study, fullscreen, sorted(with_png - shown))
    colour = [r for r in results if r["colour"]]
    assert len(colour) == 2 * 150  # every night frame, full screen and windowed
    wrong = [r for r in results if r["exact"] != 1.0 or r["worst"] != 0]
    summary = "\n".join(
        f"{r['study']} {'fullscreen' if r['fullscreen'] else 'windowed'} {r['window']} "
        f"{r['bits']} bits {r['image']}: {100 * r['exact']:.2f} % exact, worst "
        f"{r['worst']} codes, rows/columns off {r['rows_cols_off']}"
        for r in wrong[:20]
    )
    assert not wrong, f"{len(wrong)} of {len(results)} images not shown exactly:\n{summary}"
