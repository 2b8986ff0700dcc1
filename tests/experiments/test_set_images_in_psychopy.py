"""A stimulus set's images drawn by a lab's own PsychoPy experiment are the set's codes.

- An 8-bit set's ``NAME.png``, drawn as a Coder script or Builder's Image component draws a
  file (a plain ``visual.ImageStim(win, image=PATH)``, nothing else set), on an 8-bit screen.
- A 10-bit set's image drawn through the documented route, glarelab's PsychoPy plugin
  (``SetImageStim(win, image=PATH)`` on a window of ``bpc=(10, 10, 10)``, every other image
  through one stimulus's ``setImage(PATH)``, as the Builder component's "set every repeat"
  does), on a 10-bit screen.

Each image is read back from the X server by python-xlib (:meth:`tests.experiments.xscreen.
XScreen.codes`, the root window at the screen's depth) and compared with the set's codes file
decoded by OpenCV, found where it landed; neither PsychoPy, glarelab's frame-buffer read nor its
PNG decoder is taken on trust. The plugin's registration is tested as PsychoPy finds plugins:
through the entry points of an installed distribution.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import tomllib
from pathlib import Path

import numpy as np

from .test_pixel_exact import codes_file, find, png_codes
from .xscreen import XScreen

ROOT = Path(__file__).parents[2]

# shows each image alone, centred, says so and waits until the test has read the screen
SCRIPT = textwrap.dedent(
    """
    import json, sys
    from psychopy import visual

    how, folder, names = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    if how == "plain":  # as a lab's Coder script or Builder's Image component draws a file
        win = visual.Window(fullscr=True, color=(-1, -1, -1), checkTiming=False)
        make = lambda path: visual.ImageStim(win, image=path)
    else:  # the documented 10-bit route: glarelab's plugin on a 10-bit window
        from glarelab.frontend.psychopy_plugin import SetImageStim
        win = visual.Window(fullscr=True, color=(-1, -1, -1), checkTiming=False,
                            bpc=(10, 10, 10), units="pix")
        shared = SetImageStim(win, image=None)  # Builder's "set every repeat": made empty
        made = []
        def make(path):  # a new stimulus (Coder), then the shared one's setImage (Builder)
            made.append(path)
            if len(made) % 2:
                return SetImageStim(win, image=path)
            shared.setImage(path)
            return shared
    for name in names:
        stim = make(f"{folder}/{name}.png")
        stim.draw()
        win.flip()
        print("SHOWN " + json.dumps({"name": name, "window": [int(v) for v in win.size]}),
              flush=True)
        assert sys.stdin.readline().strip() == "next"
    win.close()
    print("DONE", flush=True)
    """
)


def set_folder(study: str) -> Path:
    from glarelab.protocols import load_protocol
    from glarelab.stimuli.stimulus_set import cached_stimulus_set

    return cached_stimulus_set(load_protocol(study), progress=None)


def shown_on_screen(tmp_path: Path, how: str, folder: Path, depth: int) -> list[dict]:
    """Every image of the set with a PNG, drawn by ``how`` and read back from the X server."""
    manifest = json.loads((folder / "manifest.json").read_text())
    set_bits = manifest["calibration"]["bit_depth"]
    names = sorted(n for n, r in manifest["images"].items() if r["kind"] != "component")
    script = tmp_path / "draw.py"
    script.write_text(SCRIPT)
    x = XScreen(tmp_path, depth=depth)
    found = []
    try:
        env = {
            **x.env,
            "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), os.environ.get("PYTHONPATH", "")]),
        }
        with (tmp_path / "draw.stderr").open("w") as stderr:
            process = subprocess.Popen(
                [sys.executable, str(script), how, str(folder), json.dumps(names)],
                env=env,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=stderr,
                text=True,
            )
            for line in process.stdout:
                if line.startswith("DONE"):
                    break
                if not line.startswith("SHOWN "):
                    continue
                shown = json.loads(line.removeprefix("SHOWN "))
                bits = 8 if depth == 24 else 10
                expected = png_codes(codes_file(folder, shown["name"], set_bits), set_bits, bits)
                width, height = shown["window"]
                left = (width - expected.shape[1]) / 2
                top = (height - expected.shape[0]) / 2
                band_left, band_top = max(int(left) - 2, 0), max(int(top) - 2, 0)
                band = x.codes((band_left, band_top, expected.shape[1] + 4, expected.shape[0] + 4))
                exact, worst, lines = find(band, band_left, band_top, expected, left, top)
                found.append(
                    {
                        "image": shown["name"],
                        "exact": exact,
                        "worst": worst,
                        "pixels": int(expected.shape[0] * expected.shape[1]),
                        "rows_cols_off": lines,
                    }
                )
                process.stdin.write("next\n")
                process.stdin.flush()
            process.wait(timeout=120)
    finally:
        x.close()
    log = (tmp_path / "draw.stderr").read_text()
    assert process.returncode == 0, f"the drawing failed:\n{log[-4000:]}"
    assert [f["image"] for f in found] == names
    (tmp_path / "results.json").write_text(json.dumps(found, indent=1))
    return found


def report(found: list[dict]) -> str:
    exact = sum(round(f["exact"] * f["pixels"]) for f in found)
    total = sum(f["pixels"] for f in found)
    wrong = [f for f in found if f["exact"] != 1.0 or f["worst"] != 0]
    lines = [f"{exact} of {total} pixels exact in {len(found)} images"]
    lines += [
        f"{f['image']}: {100 * f['exact']:.2f} % exact, worst {f['worst']} codes, rows/columns "
        f"off {f['rows_cols_off']}"
        for f in wrong[:20]
    ]
    return "\n".join(lines)


def test_a_plain_image_stim_shows_an_8_bit_sets_png_code_for_code(tmp_path):
    folder = set_folder("spencer1995")
    found = shown_on_screen(tmp_path, "plain", folder, depth=24)
    print(report(found))
    assert len(found) == 26  # 2 comparisons and 24 glare images
    assert all(f["exact"] == 1.0 and f["worst"] == 0 for f in found), report(found)


def test_the_plugins_set_image_stim_shows_a_10_bit_sets_codes_code_for_code(tmp_path):
    folder = set_folder("yoshida2008")
    found = shown_on_screen(tmp_path, "plugin", folder, depth=30)
    print(report(found))
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["calibration"]["bit_depth"] == 10
    assert len(found) == sum(r["kind"] != "component" for r in manifest["images"].values())
    assert all(f["exact"] == 1.0 and f["worst"] == 0 for f in found), report(found)


def test_a_plain_image_stim_of_a_10_bit_sets_png_shows_its_nearest_8_bit_codes(tmp_path):
    # the 8-bit copy beside a deeper set's codes: not a white square, the image at 8 bits
    from glarelab.stimuli.stimulus_set import read_png_codes

    folder = set_folder("yoshida2008")
    codes, bits = read_png_codes(folder / "reference_vos_f_10bit.png")
    eight, eight_bits = read_png_codes(folder / "reference_vos_f.png")
    assert (bits, eight_bits) == (10, 8)
    assert np.array_equal(eight, np.rint(codes * 255 / 1023))


# --- the plugin, as PsychoPy finds it -----------------------------------------------------------

REGISTERED = textwrap.dedent(
    """
    import sys
    from psychopy import plugins, visual
    from psychopy.experiment import components

    plugins.scanPlugins()
    assert "glarelab" in plugins.listPlugins(), plugins.listPlugins()
    assert plugins.loadPlugin("glarelab"), "glarelab did not load as a plugin"
    from glarelab.frontend.psychopy_plugin import SetImageStim
    from glarelab.frontend.psychopy_builder import SetImageComponent
    assert visual.SetImageStim is SetImageStim
    assert components.getAllComponents(fetchIcons=False)["SetImageComponent"] is SetImageComponent
    for wrong, message in ((dict(units="norm"), "units must be 'pix' (one image pixel on one "
                            "screen pixel); got 'norm'"),
                           (dict(interpolate=True), "interpolate is fixed by SetImageStim")):
        try:
            visual.SetImageStim(None, image="x.png", **wrong)
        except ValueError as error:
            assert str(error).startswith(message), error
        else:
            raise AssertionError(f"{wrong} was taken")
    print("REGISTERED")
    """
)


def test_psychopy_loads_glarelab_as_a_plugin_from_its_entry_points(tmp_path):
    # and its stimulus refuses what would scale the codes
    # an installed distribution of glarelab whose entry points are pyproject.toml's, as pip
    # writes them (PsychoPy scans the distributions on sys.path)
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())
    points = project["project"]["entry-points"]
    assert set(points) == {"psychopy.visual", "psychopy.experiment.components"}
    site = tmp_path / "site"
    info = site / "glarelab-0.0.0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: glarelab\nVersion: 0.0.0\n")
    (info / "entry_points.txt").write_text(
        "".join(
            f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in table.items()) + "\n"
            for group, table in points.items()
        )
    )
    x = XScreen(tmp_path)  # psychopy.visual opens pyglet's hidden window
    try:
        env = {
            **x.env,
            "PYTHONPATH": os.pathsep.join([str(site), str(ROOT / "src")]),
            "PYTHONNOUSERSITE": "1",
        }
        done = subprocess.run(
            [sys.executable, "-c", REGISTERED],
            env=env,
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
    finally:
        x.close()
    assert done.returncode == 0 and "REGISTERED" in done.stdout, done.stderr[-3000:]


def test_the_builder_component_compiles_to_the_plugins_stimulus(tmp_path):
    from psychopy import experiment

    from glarelab.frontend.psychopy_builder import SetImageComponent

    exp = experiment.Experiment()
    exp.addRoutine("trial")
    routine = exp.routines["trial"]
    exp.flow.addRoutine(routine, 0)
    component = SetImageComponent(exp, "trial", name="glare", image="sets/yoshida/ref.png")
    routine.addComponent(component)
    script = exp.writeScript(target="PsychoPy")
    assert "from glarelab.frontend.psychopy_plugin import SetImageStim" in script
    assert "glare = SetImageStim(" in script and "image='sets/yoshida/ref.png'" in script
    compile(script, "experiment.py", "exec")
    component.params["image"].updates = "set every repeat"
    script = exp.writeScript(target="PsychoPy")
    assert "image=None" in script and "glare.setImage('sets/yoshida/ref.png')" in script
    for fixed in ("size", "units", "color", "interpolate"):
        assert fixed not in component.params or fixed == "interpolate"
