"""Using the suite leaves numpy's global options as they were (colour-science sets its print
options to legacy 1.13 when first imported, which would change every float a user prints)."""

import subprocess
import sys

USE_EVERY_COLOUR_MODULE = """
import numpy as np
before = np.get_printoptions()
from glarelab import glare
from glarelab.glare import acuity, adaptation, scotopic, wave
from glarelab.stimuli import preview
from glarelab import analysis
glare.WaveOpticsGlare(pupil_mm=3.0)
import colour
assert "colour" in __import__("sys").modules
changed = {k: (v, np.get_printoptions()[k]) for k, v in before.items() if np.get_printoptions()[k] != v}
print(repr(changed))
"""


def test_importing_every_module_that_uses_colour_science_keeps_numpy_print_options():
    out = subprocess.run(
        [sys.executable, "-c", USE_EVERY_COLOUR_MODULE],
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    )
    assert out.stdout.strip() == "{}"
