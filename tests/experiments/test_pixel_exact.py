"""What the participant sees is the stimulus set, code for code: every image of each shipped
matching and staircase study, shown by the session's own front-end in a real PsychoPy window on
an X server of 8 and 10 bits per channel, full screen and windowed, read back from the frame
buffer as the front-end flips it (the back buffer, just before the flip that shows it) and
compared pixel for pixel with the set's PNG codes (rounded to the window's bits).

The read-back here is the test's own (``glReadPixels`` at 16 bits per channel) and the images
are found where they landed (the best whole-pixel offset near the centred row), so neither the
front-end's layout nor ``check-display`` is taken on trust.
"""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from .xscreen import XScreen

ROOT = Path(__file__).parents[2]
STUDIES = ("yoshida2008", "glare_methods2026", "spencer1995")

SCRIPT = textwrap.dedent(
    """
    import ctypes, json, sys
    from pathlib import Path

    import numpy as np

    from glarelab.experiments.psychopy_frontend import PsychoPyFrontend
    from glarelab.protocols import load_protocol
    from glarelab.stimuli.stimulus_set import read_codes

    def frame_codes(window, bits):
        # the 320 rows around the window's middle (the images' row), every column, top row
        # first, and the first one's number from the bottom (OpenGL's)
        from pyglet import gl
        width, height = (int(v) for v in window.size)
        bottom, rows = height // 2 - 160, 320
        buffer = (ctypes.c_ushort * (width * rows * 3))()
        gl.glReadBuffer(gl.GL_BACK)
        gl.glPixelStorei(gl.GL_PACK_ALIGNMENT, 1)
        gl.glReadPixels(0, bottom, width, rows, gl.GL_RGB, gl.GL_UNSIGNED_SHORT, buffer)
        values = np.frombuffer(buffer, dtype=np.uint16).reshape(rows, width, 3)[::-1]
        return bottom, np.rint(values * ((2**bits - 1) / 65535)).astype(np.int64)

    def screens(manifest):
        kinds = {name: r["kind"] for name, r in manifest["images"].items()}
        one = lambda role, name: {"role": role, "terms": [(name, 1.0)]}
        if manifest["paradigm"] == "matching":
            for name in sorted(n for n, k in kinds.items() if k == "reference"):
                yield {"kind": "adjust", "trial": 1, "images": [
                    one("left", "target_start_darker"), one("reference", name),
                    one("right", "target_start_brighter")],
                    "labels": {"left": "darker", "right": "brighter"}, "marker": "left",
                    "keys": {}}
        else:
            glare = sorted(n for n, k in kinds.items() if k == "glare")
            for i, name in enumerate(glare):
                context = manifest["images"][name]["context"]
                pair = [one("glare", name), one("comparison", f"comparison_{context}_full")]
                yield {"kind": "adjust", "trial": 1, "images": pair[:: 1 if i % 2 else -1],
                       "prompt": "Which disc looked brighter?", "keys": {}}

    def find(band, expected, left, bottom):
        # the best whole-pixel offset near the nominal (possibly half-pixel) edges
        band_bottom, frame = band
        height, width = expected.shape[:2]
        best = (-1.0, None, None)
        for x in range(int(np.floor(left)) - 1, int(np.ceil(left)) + 2):
            for y in range(int(np.floor(bottom)) - 1, int(np.ceil(bottom)) + 2):
                top = band_bottom + frame.shape[0] - y - height
                if x < 0 or top < 0 or x + width > frame.shape[1] or top + height > frame.shape[0]:
                    continue
                shown = frame[top:top + height, x:x + width]
                equal = np.all(shown == expected, axis=-1)
                if equal.mean() > best[0]:
                    rows = int(np.sum(~equal.all(axis=1)))
                    cols = int(np.sum(~equal.all(axis=0)))
                    best = (float(equal.mean()), int(np.abs(shown - expected).max()),
                            [rows, cols])
        return best

    results = []
    for study, folder in json.loads(sys.argv[1]).items():
        protocol = load_protocol(study)
        manifest = json.loads((Path(folder) / "manifest.json").read_text())
        gap = manifest["geometry"]["gap_px"]
        for fullscreen in (True, False):
            device = PsychoPyFrontend(protocol, stimuli=folder, fullscreen=fullscreen,
                                      scripted_keys=[])
            facts = device.open()
            bits = facts.bits_per_channel
            width, height = (int(v) for v in device.window.size)
            flip, frames = device.window.flip, []

            def read_then_flip(*args, **kwargs):  # what the flip is about to show
                frames.append(frame_codes(device.window, bits))
                return flip(*args, **kwargs)

            device.window.flip = read_then_flip
            try:
                for screen in screens(manifest):
                    frames.clear()
                    device.show(screen)
                    (frame,) = frames
                    names = [image["terms"][0][0] for image in screen["images"]]
                    codes = [read_codes(Path(folder) / f"{n}.png") for n in names]
                    sizes = [c.shape[1] for c, _ in codes]
                    x = (width - sum(sizes) - gap * (len(sizes) - 1)) / 2
                    for name, (code, set_bits) in zip(names, codes):
                        expected = np.rint(code * ((2**bits - 1) / (2**set_bits - 1)))
                        expected = expected.astype(np.int64)
                        if expected.ndim == 2:
                            expected = np.repeat(expected[..., None], 3, axis=-1)
                        exact, worst, lines = find(
                            frame, expected, x, (height - expected.shape[0]) / 2)
                        x += expected.shape[1] + gap
                        results.append({"study": study, "fullscreen": fullscreen,
                                        "bits": bits, "window": [width, height],
                                        "image": name, "exact": exact, "worst": worst,
                                        "rows_cols_off": lines})
            finally:
                device.close()
    print("RESULTS " + json.dumps(results))
    """
)


@pytest.fixture(scope="module")
def study_sets():
    from glarelab.protocols import load_protocol
    from glarelab.stimuli.stimulus_set import cached_stimulus_set

    return {
        study: str(cached_stimulus_set(load_protocol(study), progress=None)) for study in STUDIES
    }


def read_back(tmp_path: Path, depth: int, sets: dict) -> list[dict]:
    script = tmp_path / "read_back.py"
    script.write_text(SCRIPT)
    x = XScreen(tmp_path, depth=depth)
    try:
        env = {
            **x.env,
            "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        }
        done = subprocess.run(
            [sys.executable, str(script), json.dumps(sets)],
            env=env,
            capture_output=True,
            text=True,
            timeout=600,
            check=False,
        )
    finally:
        x.close()
    lines = [line for line in done.stdout.splitlines() if line.startswith("RESULTS ")]
    assert lines, f"the read-back failed:\n{done.stdout[-2000:]}\n{done.stderr[-4000:]}"
    (tmp_path / "results.json").write_text(lines[0].removeprefix("RESULTS "))
    return json.loads(lines[0].removeprefix("RESULTS "))


@pytest.mark.parametrize("depth, bits", [(24, 8), (30, 10)])
def test_every_image_is_shown_code_for_code(tmp_path, study_sets, depth, bits):
    results = read_back(tmp_path, depth, study_sets)
    assert {r["bits"] for r in results} == {bits}  # the window has the screen's bits
    for study in STUDIES:
        for fullscreen in (True, False):
            shown = [r for r in results if r["study"] == study and r["fullscreen"] == fullscreen]
            assert len(shown) >= 36, (study, fullscreen)  # every screen of the set, read back
    wrong = [r for r in results if r["exact"] != 1.0 or r["worst"] != 0]
    summary = "\n".join(
        f"{r['study']} {'fullscreen' if r['fullscreen'] else 'windowed'} {r['window']} "
        f"{r['bits']} bits {r['image']}: {100 * r['exact']:.2f} % exact, worst "
        f"{r['worst']} codes, rows/columns off {r['rows_cols_off']}"
        for r in wrong[:20]
    )
    assert not wrong, f"{len(wrong)} of {len(results)} images not shown exactly:\n{summary}"
