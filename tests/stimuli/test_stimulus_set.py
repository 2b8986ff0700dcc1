import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from protocols import load_protocol
from stimuli.exr import read_exr
from stimuli.stimulus_set import build_stimulus_set, default_calibration, verify_stimulus_set

PROTOCOLS = Path(__file__).parents[2] / "protocols"


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
        codes = np.asarray(Image.open(tmp_path / f"{name}.png"))
        assert codes.dtype == np.uint16 and codes.max() <= 1023
        decoded = calibration.decode(codes)
        step = calibration.step_cd_m2(codes)
        assert (np.abs(decoded - luminance) <= step / 2 + 1e-6).all()
    assert manifest["images"]["reference_vos_f"]["encoding"]["above_max"] == 0


def test_a_calibration_for_another_bit_depth_is_refused(tmp_path):
    from stimuli.calibration import synthetic_calibration

    protocol = load_protocol(PROTOCOLS / "yoshida2008.toml")
    eight_bit = synthetic_calibration(max_cd_m2=433.0, black_cd_m2=0.5, bit_depth=8)
    with pytest.raises(ValueError, match="8-bit display, the protocol's display is 10-bit"):
        build_stimulus_set(protocol, tmp_path, calibration=eight_bit, progress=None)
    luidolt = load_protocol(PROTOCOLS / "luidolt2020.toml")
    with pytest.raises(ValueError, match="shows no images: there is no stimulus set to build"):
        build_stimulus_set(luidolt, tmp_path, progress=None)
