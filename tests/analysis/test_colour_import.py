"""The analysis takes colour-science from glare's import of it: importing the analysis loads no
colour-science at all, and the sRGB encoding of a report's stimuli, which loads it, leaves
numpy's print options as they were (colour-science sets legacy 1.13 printing when imported)."""

import subprocess
import sys

ENCODE_IN_A_FRESH_PROCESS = """
import sys
import numpy as np
before = np.get_printoptions()
import glarelab.analysis.report
print("colour" in sys.modules)
from glarelab.analysis.stimulus_figures import to_srgb8
print(to_srgb8(np.array([0.0, 21.6, 120.0]), 120.0).tolist())
print("colour" in sys.modules)
print({k: v for k, v in np.get_printoptions().items() if before[k] != v})
"""


def test_the_report_loads_colour_science_when_it_encodes_and_keeps_numpy_printing():
    done = subprocess.run(
        [sys.executable, "-c", ENCODE_IN_A_FRESH_PROCESS],
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    )
    # IEC 61966-2-1: 18 % relative luminance encodes to 118 of 255
    assert done.stdout.split("\n")[:4] == ["False", "[0, 118, 255]", "True", "{}"]
