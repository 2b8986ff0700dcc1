"""Every command refuses bad input the same way: a non-zero exit, one message naming the
argument or file, no traceback, and no file changed anywhere (a refusal writes nothing).

The catalogue runs each case in a sandbox of good and bad files (images, a stimulus set,
session data, calibrations, protocols) and compares the sandbox's every file before and after.
The cases that destroyed data or tricked a stimulus set have their own tests below.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from glarelab.cli import main
from glarelab.experiments.session import SimulatedFrontend, make_observer, run_session
from glarelab.files.folders import record_files
from glarelab.protocols import load_protocol
from glarelab.stimuli.exr import write_exr
from glarelab.stimuli.stimulus_set import cached_stimulus_set, verify_stimulus_set
from tests.conftest import reseal

ROOT = Path(__file__).parents[1]
PROTOCOLS = ROOT / "src" / "glarelab" / "protocols"


def _simulate(protocol, folder: Path, participants: int, stimuli=None) -> list[Path]:
    for number in range(1, participants + 1):
        observer = make_observer(protocol, f"sim{number:02d}", seed=1, stimuli=stimuli)
        run_session(
            protocol,
            f"sim{number:02d}",
            out=folder,
            frontend=SimulatedFrontend(observer),
            stimuli=stimuli,
            simulated=True,
        )
    return sorted(folder.glob(f"*_{protocol.study}_s1_*.csv"))


def _variant(path: Path, out: Path, change) -> Path:
    """A copy of a session CSV (and its sidecar) with ``change(frame)`` applied."""
    data = pd.read_csv(path, dtype=str, keep_default_na=False)
    data = change(data)
    data.to_csv(out, index=False)
    shutil.copy(path.with_suffix(".json"), out.with_suffix(".json"))
    return out


@pytest.fixture(scope="module")
def sandbox(tmp_path_factory) -> Path:
    box = tmp_path_factory.mktemp("bad-inputs")
    # images
    image = np.full((64, 64), 0.5, np.float32)
    image[30:34, 30:34] = 1e5
    write_exr(box / "good.exr", image)
    (box / "empty.exr").write_bytes(b"")
    (box / "text.exr").write_text("linear luminance, honestly\n")
    from PIL import Image

    Image.fromarray(np.zeros((8, 8), np.uint8)).save(box / "picture.png")
    shutil.copy(box / "picture.png", box / "png-named.exr")
    good = (box / "good.exr").read_bytes()
    (box / "truncated.exr").write_bytes(good[: len(good) // 2])
    (box / "a").mkdir()
    (box / "b").mkdir()
    write_exr(box / "a" / "same.exr", image)
    write_exr(box / "b" / "same.exr", image)
    (box / "afolder").mkdir()
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    both = {"Y": image, "R": image, "G": image, "B": image}
    with OpenEXR.File(header, both) as exr:
        exr.write(str(box / "y-and-rgb.exr"))
    (box / "afile.txt").write_text("a file\n")
    (box / "foreign").mkdir()
    (box / "foreign" / "notes.txt").write_text("someone else's\n")
    # calibrations
    (box / "calibration-text.json").write_text("not json\n")
    (box / "calibration-list.json").write_text("[1, 2, 3]\n")
    shutil.copy(ROOT / "calibrations" / "SYNTHETIC-spencer1995-50cd-8bit.json", box / "8bit.json")
    (box / "readings-down.csv").write_text(
        "code,luminance_cd_m2\n0,0.5\n300,50\n600,40\n1023,400\n"
    )
    (box / "readings-latin1.csv").write_bytes(b"code,luminance_cd_m2,note\n0,0.5,\xe4\n")
    (box / "special").mkdir()  # what is not a regular file, given as one
    os.mkfifo(box / "special" / "fifo")
    (box / "special" / "loop").symlink_to(box / "special" / "loop-back")  # a loop of links
    (box / "special" / "loop-back").symlink_to(box / "special" / "loop")
    shutil.copy(ROOT / "calibrations" / "example-readings.csv", box / "readings-good.csv")
    (box / "readings-tab.csv").write_text("code\tluminance_cd_m2\n0\t0.5\n255\t200\n")
    # protocols
    yoshida = (PROTOCOLS / "yoshida2008.toml").read_text()
    assert 'labels = ["A", "B", "C", "D", "E", "F"]' in yoshida
    (box / "duplicate-labels.toml").write_text(
        yoshida.replace(
            'labels = ["A", "B", "C", "D", "E", "F"]', 'labels = ["A", "A", "C", "D", "E", "F"]'
        )
    )
    (box / "escaping-label.toml").write_text(
        yoshida.replace(
            'labels = ["A", "B", "C", "D", "E", "F"]',
            'labels = ["../../../escaped", "B", "C", "D", "E", "F"]',
        )
    )
    luidolt = (PROTOCOLS / "luidolt2020.toml").read_text()
    assert "scale_max = 7" in luidolt
    (box / "scale10.toml").write_text(luidolt.replace("scale_max = 7", "scale_max = 10"))
    (box / "syntax.toml").write_text("[study\nname = 'x'\n")
    assert yoshida.count('name = "gaussian"') == 1
    (box / "observer-range.toml").write_text(yoshida + "\n[observer]\nglow_gain = -1\n")
    (box / "observer-unknown.toml").write_text(yoshida + "\n[observer]\nglo_gain = 1\n")
    (box / "newline-name.toml").write_text(
        yoshida.replace('name = "gaussian"', 'name = "gaus\nsian"')
    )
    from tests.conftest import small_night_protocol

    night = small_night_protocol()
    (box / "night-small.toml").write_text(night)
    display = night[night.index("[display]") : night.index("[viewing]")]
    (box / "night-no-display.toml").write_text(night.replace(display, ""))
    assert 'effects = ["glare", "acuity", "scotopic"]' in night
    (box / "night-bad-effect.toml").write_text(
        night.replace('effects = ["glare", "acuity", "scotopic"]', 'effects = ["glow"]')
    )
    # a stimulus set and session data
    protocol = load_protocol("yoshida2008")
    shutil.copytree(cached_stimulus_set(protocol, progress=None), box / "set")
    data = box / "data"
    data.mkdir()
    first, second = _simulate(protocol, data, 2, stimuli=box / "set")
    _simulate(load_protocol("luidolt2020"), data, 1)
    bad = box / "bad-data"
    bad.mkdir()

    def set_cell(column, value, row=0):
        def change(frame):
            frame.loc[row, column] = value
            return frame

        return change

    _variant(first, bad / "huge.csv", set_cell("match_cd_m2", "1e300"))
    _variant(first, bad / "above-display.csv", set_cell("match_cd_m2", "99999"))
    _variant(first, bad / "nan.csv", set_cell("match_cd_m2", "nan"))
    main_row = int(pd.read_csv(first)["block"].eq("main").idxmax())
    _variant(first, bad / "relabelled.csv", set_cell("level", "Z", main_row))
    level = pd.read_csv(first, keep_default_na=False).loc[main_row, "level"]
    mislabelled = _variant(
        first, bad / "mislabelled.csv", set_cell("level", "B" if level != "B" else "C", main_row)
    )
    # the sidecar's trial order edited to agree (else that check names the row first)
    sidecar = json.loads(mislabelled.with_suffix(".json").read_text())
    entry = sidecar["trial_order"][main_row].rsplit(":", 1)[0]
    sidecar["trial_order"][main_row] = f"{entry}:{'B' if level != 'B' else 'C'}"
    mislabelled.with_suffix(".json").write_text(json.dumps(sidecar))
    _variant(first, bad / "header-only.csv", lambda frame: frame.iloc[:0])
    aborted = _variant(first, bad / "aborted.csv", lambda frame: frame.iloc[:-3])
    sidecar = json.loads(aborted.with_suffix(".json").read_text())
    trials = len(pd.read_csv(aborted))
    sidecar |= {"status": "aborted", "trials": trials}  # its runs as a session writes them
    sidecar["runs"][-1] |= {"status": "aborted", "trials_after": trials, "ended_by": "escape"}
    aborted.with_suffix(".json").write_text(json.dumps(sidecar))
    shutil.copy(second, bad / "second.csv")
    shutil.copy(second.with_suffix(".json"), bad / "second.json")
    (box / "scripted-none.txt").write_text("\n")
    (box / "report-here").mkdir()
    (box / "report-here" / "participant.csv").write_text("participant,answer\nP01,yes\n")
    # a power analysis's folder, of seed 1
    power = ["power", "luidolt2020", "--participants", "3", "--replications", "1"]
    assert main([*power, "--workers", "0", "--out", str(box / "power-done")]) == 0
    return box


def snapshot(root: Path) -> dict[str, tuple]:
    """Every file and folder under ``root`` with its size, inode and modification time."""
    state = {}
    for folder, folders, files in os.walk(root):
        for name in folders + files:
            path = Path(folder) / name
            info = path.lstat()
            state[str(path.relative_to(root))] = (info.st_size, info.st_ino, info.st_mtime_ns)
    return state


def refused(argv: list[str], capsys) -> tuple[int, str]:
    """Run the command in this process: its exit status and what it wrote on stderr."""
    try:
        status = main(argv)
    except SystemExit as stop:  # argparse refuses with SystemExit(2)
        status = stop.code
    return status, capsys.readouterr().err


# (case, command line with {box} for the sandbox, what the message must name); every case
# exits non-zero, prints no traceback and changes no file
CASES = [
    # render: inputs
    (
        "render-empty",
        "render {box}/empty.exr {box}/out.exr --pixel-deg 0.02",
        "empty.exr is an empty file",
    ),
    (
        "render-text",
        "render {box}/text.exr {box}/out.exr --pixel-deg 0.02",
        "text.exr is not an OpenEXR",
    ),
    (
        "render-png",
        "render {box}/png-named.exr {box}/out.exr --pixel-deg 0.02",
        "png-named.exr is not an OpenEXR",
    ),
    (
        "render-truncated",
        "render {box}/truncated.exr {box}/out.exr --pixel-deg 0.02",
        "truncated.exr cannot be read",
    ),
    (
        "render-missing",
        "render {box}/none.exr {box}/out.exr --pixel-deg 0.02",
        "none.exr: no such file",
    ),
    (
        "render-folder",
        "render {box}/afolder {box}/out.exr --pixel-deg 0.02",
        "input {box}/afolder: a folder, not a file",
    ),
    (
        "render-fifo",
        "render {box}/special/fifo {box}/out.exr --pixel-deg 0.02",
        "input {box}/special/fifo: a named pipe (FIFO), not a regular file",
    ),
    (
        "render-one-path",
        "render {box}/good.exr --pixel-deg 0.02",
        "needs an input EXR and an output",
    ),
    # render: outputs
    (
        "render-over-input",
        "render {box}/good.exr {box}/good.exr --pixel-deg 0.02",
        "is also an input",
    ),
    (
        "render-png-name",
        "render {box}/good.exr {box}/out.png --pixel-deg 0.02",
        "must be named .exr",
    ),
    (
        "render-no-folder",
        "render {box}/good.exr {box}/nowhere/out.exr --pixel-deg 0.02",
        "no folder",
    ),
    (
        "render-preview-exr",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --preview {box}/p.exr",
        "preview must be named .png",
    ),
    (
        "render-preview-many",
        "render {box}/good.exr {box}/empty.exr {box}/outs/ --pixel-deg 0.02 --preview {box}/p.png",
        "--preview is for one output",
    ),
    (
        "render-same-names",
        "render {box}/a/same.exr {box}/b/same.exr {box}/outs/ --pixel-deg 0.02",
        "same file name",
    ),
    (
        "render-into-file",
        "render {box}/good.exr {box}/empty.exr {box}/afile.txt --pixel-deg 0.02",
        "afile.txt is a file",
    ),
    # render: numbers
    (
        "render-tolerance-negative",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --tolerance-codes -1",
        "--tolerance-codes: -1",
    ),
    (
        "render-tolerance-nan",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --tolerance-codes nan",
        "--tolerance-codes: nan",
    ),
    (
        "render-pixel-huge",
        "render {box}/good.exr {box}/out.exr --pixel-deg 1e3",
        "--pixel-deg: 1e3",
    ),
    ("render-pixel-zero", "render {box}/good.exr {box}/out.exr --pixel-deg 0", "--pixel-deg: 0"),
    (
        "render-pixel-text",
        "render {box}/good.exr {box}/out.exr --pixel-deg wide",
        "--pixel-deg: 'wide' is not a number",
    ),
    (
        "render-l-dmax",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --l-dmax -5",
        "--l-dmax: -5",
    ),
    ("render-age", "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --age -5", "--age: -5"),
    (
        "render-sigma",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --model gaussian --sigma-deg 0",
        "--sigma-deg: 0",
    ),
    (
        "render-pupil",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --model wave --pupil-mm 0",
        "--pupil-mm: 0",
    ),
    (
        "render-wavelength",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --wavelength-nm inf",
        "--wavelength-nm: inf",
    ),
    (
        "render-model",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --model sun",
        "--model: invalid choice: 'sun'",
    ),
    (
        "render-particles",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --particles -1",
        "--particles: -1",
    ),
    (
        "render-calibration-text",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --calibration {box}/calibration-text.json",
        "calibration-text.json: a calibration must be a JSON file",
    ),
    (
        "render-calibration-list",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --calibration {box}/calibration-list.json",
        "calibration-list.json: not a glarelab calibration",
    ),
    # psf, gallery, looks
    ("psf-even", "psf --out {box}/k.png --size 400", "--size: 400 must be odd"),
    (
        "psf-huge",
        "psf --out {box}/k.png --size 20001",
        "--size: 20001 must be a whole number from 3 to 16385",
    ),
    ("psf-jpg", "psf --out {box}/k.jpg --model vos", "kernel image must be named .png"),
    (
        "psf-exr-name",
        "psf --out {box}/k.png --exr {box}/k.png --model vos",
        "kernel must be named .exr",
    ),
    ("psf-pixel", "psf --out {box}/k.png --model vos --pixel-deg -0.1", "--pixel-deg: -0.1"),
    ("gallery-file", "gallery --out {box}/afile.txt --size 11", "afile.txt is a file"),
    ("gallery-size", "gallery --out {box}/gallery --size 2", "--size: 2"),
    ("looks-file", "looks --out {box}/afile.txt", "afile.txt is a file"),
    ("looks-night-file", "looks --night --out {box}/afile.txt", "afile.txt is a file"),
    # stimuli
    ("build-unknown", "stimuli build yoshida2009 --out {box}/newset", "yoshida2009"),
    (
        "build-night-no-display",
        "stimuli build {box}/night-no-display.toml --out {box}/newset",
        "[display]: missing",
    ),
    (
        "build-night-bad-effect",
        "stimuli build {box}/night-bad-effect.toml --out {box}/newset",
        "'glow'",
    ),
    (
        "build-duplicate-labels",
        "stimuli build {box}/duplicate-labels.toml --out {box}/newset",
        "labels",
    ),
    (
        "build-escaping-label",
        "stimuli build {box}/escaping-label.toml --out {box}/newset",
        "../../../escaped",
    ),
    ("build-into-file", "stimuli build yoshida2008 --out {box}/afile.txt", "afile.txt is a file"),
    (
        "build-into-foreign",
        "stimuli build yoshida2008 --out {box}/foreign",
        "foreign holds files that are not an earlier stimulus set",
    ),
    (
        "build-calibration-text",
        "stimuli build yoshida2008 --out {box}/newset --calibration {box}/calibration-text.json",
        "calibration-text.json",
    ),
    (
        "build-calibration-bits",
        "stimuli build yoshida2008 --out {box}/newset --calibration {box}/8bit.json",
        "8-bit display",
    ),
    ("build-rating", "stimuli build luidolt2020 --out {box}/newset", "shows no images"),
    ("verify-not-folder", "stimuli verify {box}/afile.txt", "not a folder"),
    (
        "verify-no-manifest",
        "stimuli verify {box}/foreign",
        "foreign: no manifest.json, so not a stimulus set",
    ),
    # protocol
    ("protocol-missing-file", "protocol check {box}/none.toml", "none.toml"),
    ("protocol-scale-10", "protocol check {box}/scale10.toml", "questionnaire.scale_max"),
    ("protocol-syntax", "protocol check {box}/syntax.toml", "syntax.toml"),
    (
        "protocol-observer-range",
        "protocol check {box}/observer-range.toml",
        "{box}/observer-range.toml: observer.glow_gain must be in [0, 10], got -1",
    ),
    (
        "protocol-observer-unknown",
        "protocol check {box}/observer-unknown.toml",
        "{box}/observer-unknown.toml: observer: unknown key(s) glo_gain (known: block_sd,",
    ),
    (
        "protocol-newline-in-name",
        "protocol check {box}/newline-name.toml",
        "glare.methods.name (line 42): not valid TOML: Illegal character '\\n'",
    ),
    ("protocol-keys-unknown", "protocol keys nonsense", "nonsense"),
    # calibrate
    ("fit-missing", "calibrate fit {box}/none.csv --out {box}/c.json", "none.csv"),
    (
        "fit-devnull",
        "calibrate fit /dev/null --out {box}/c.json",
        "readings file /dev/null: a device (as /dev/null is), not a regular file",
    ),
    (
        "fit-folder",
        "calibrate fit {box}/afolder --out {box}/c.json",
        "readings file {box}/afolder: a folder, not a file",
    ),
    (
        "fit-fifo",
        "calibrate fit {box}/special/fifo --out {box}/c.json",
        "readings file {box}/special/fifo: a named pipe (FIFO), not a regular file",
    ),
    (
        "fit-latin1",
        "calibrate fit {box}/readings-latin1.csv --out {box}/c.json",
        "readings-latin1.csv: byte 32 is not UTF-8 text; save it as UTF-8",
    ),
    (
        "fit-tab-separated",  # its header read as one column's name
        "calibrate fit {box}/readings-tab.csv --out {box}/c.json",
        "readings-tab.csv, line 1: missing column(s) ['code', 'luminance_cd_m2']: the first "
        "line must name the columns, comma-separated (code,luminance_cd_m2; other columns are "
        "ignored); it is 'code\\tluminance_cd_m2'",
    ),
    (
        "fit-out-loop",
        "calibrate fit {box}/readings-good.csv --out {box}/special/loop/c.json",
        "{box}/special/loop/c.json: a loop of symbolic links on the way; the calibration needs",
    ),
    (
        "build-out-loop",  # refused before the images are made
        "stimuli build yoshida2008 --out {box}/special/loop/set",
        "{box}/special/loop/set: a loop of symbolic links on the way; the stimulus set needs",
    ),
    (
        "analyse-out-loop",
        "analyse yoshida2008 {box}/data/sim01_*.csv --out {box}/special/loop/report",
        "special/loop/report: a loop of symbolic links on the way; the report needs a path",
    ),
    (
        "protocol-fifo",
        "protocol check {box}/special/fifo",
        "protocol file {box}/special/fifo: a named pipe (FIFO)",
    ),
    ("protocol-folder", "protocol check {box}/afolder", "protocol file {box}/afolder: a folder"),
    (
        "build-calibration-devnull",
        "stimuli build yoshida2008 --calibration /dev/null --out {box}/s",
        "calibration file /dev/null: a device",
    ),
    (
        "fit-txt",
        "calibrate fit {box}/readings-down.csv --out {box}/c.txt",
        "calibration must be named .json",
    ),
    (
        "fit-decreasing",
        "calibrate fit {box}/readings-down.csv --out {box}/c.json",
        "not increasing",
    ),
    (
        "fit-bits",
        "calibrate fit {box}/readings-down.csv --out {box}/c.json --bit-depth 9",
        "--bit-depth: invalid choice: 9",
    ),
    ("measure-points", "calibrate measure --out {box}/c.json --points 2", "--points: 2"),
    ("measure-tolerance", "calibrate measure --out {box}/c.json --tolerance 0", "--tolerance: 0"),
    (
        "measure-csv",
        "calibrate measure --out {box}/c.csv --simulate 400 0.5 2.2",
        "calibration must be named .json",
    ),
    (
        "measure-simulate",
        "calibrate measure --out {box}/c.json --simulate 400 0.5 nan",
        "--simulate: nan",
    ),
    # run
    (
        "run-participants-0",
        "run luidolt2020 --simulate --participants 0 --out {box}/runs",
        "--participants: 0",
    ),
    (
        "run-participants-negative",
        "run luidolt2020 --simulate --participants -2 --out {box}/runs",
        "--participants: -2",
    ),
    (
        "run-participant-empty",
        "run luidolt2020 --simulate --participant= --out {box}/runs",
        "--participant: must be",
    ),
    (
        "run-participant-path",
        "run luidolt2020 --simulate --participant ../P1 --out {box}/runs",
        "--participant: must be",
    ),
    (
        "run-age",
        "run luidolt2020 --participant P1 --age -5 --out {box}/runs",
        "--age: age must be 0-120",
    ),
    ("run-session", "run luidolt2020 --simulate --session 0 --out {box}/runs", "--session: 0"),
    ("run-out-file", "run luidolt2020 --simulate --out {box}/afile.txt", "afile.txt is a file"),
    ("run-unknown-study", "run yoshida2009 --simulate --out {box}/runs", "yoshida2009"),
    (
        "run-night-no-set",
        "run {box}/night-small.toml --participant P01 --out {box}/runs",
        "--stimuli",
    ),
    (
        "run-night-other-set",
        "run {box}/night-small.toml --participant P01 --stimuli {box}/set --out {box}/runs",
        "built from another protocol",
    ),
    (
        "run-simulate-other-set",  # the observers looked at the set before it was checked
        "run spencer1995 --simulate --participants 1 --stimuli {box}/set --out {box}/runs",
        "built from another protocol (yoshida2008)",
    ),
    (
        "analyse-night-other-data",
        "analyse {box}/night-small.toml {box}/data/*luidolt2020*.csv --out {box}/nightreport",
        "columns do not match",
    ),
    (
        "run-scripted-none",
        "run luidolt2020 --participant P1 --scripted-keys {box}/none.txt --out {box}/runs",
        "no --scripted-keys file at {box}/none.txt",
    ),
    (
        "run-scripted-fifo",
        "run luidolt2020 --participant P1 --scripted-keys {box}/special/fifo --out {box}/runs",
        "--scripted-keys file {box}/special/fifo: a named pipe (FIFO), not a regular file",
    ),
    (
        "run-scripted-empty",
        "run luidolt2020 --participant P1 --scripted-keys {box}/scripted-none.txt --out {box}/runs",
        "names no keys",
    ),
    (
        "run-screenshot-jpg",
        "run luidolt2020 --participant P1 --screenshot {box}/s.jpg --out {box}/runs",
        "screenshot must be named .png",
    ),
    (
        "run-counterbalance",
        "run spencer1995 --simulate --counterbalance 2 --out {box}/runs",
        "--counterbalance: invalid choice: 2",
    ),
    # analyse
    (
        "analyse-other-protocol",
        "analyse yoshida2008 {box}/data/sim01_yoshida2008_s1_*.csv --protocol "
        + str(PROTOCOLS / "spencer1995.toml")
        + " --out {box}/report",
        "study 'spencer1995', not of 'yoshida2008'",
    ),
    (
        "analyse-wrong-study",
        "analyse spencer1995 {box}/bad-data/second.csv --out {box}/report",
        "its study column says 'yoshida2008'",
    ),
    (
        "analyse-huge",
        "analyse yoshida2008 {box}/bad-data/huge.csv {box}/bad-data/second.csv --out {box}/report",
        "huge.csv, line 2, column match_cd_m2",
    ),
    (
        "analyse-above-display",
        "analyse yoshida2008 {box}/bad-data/above-display.csv {box}/bad-data/second.csv --out {box}/report",
        "cannot be shown on the protocol's display",
    ),
    (
        "analyse-nan",
        "analyse yoshida2008 {box}/bad-data/nan.csv {box}/bad-data/second.csv --out {box}/report",
        "nan.csv, line 2, column match_cd_m2: 'nan'",
    ),
    (
        "analyse-relabelled",
        "analyse yoshida2008 {box}/bad-data/relabelled.csv {box}/bad-data/second.csv --out {box}/report",
        "column level: 'Z'",
    ),
    (
        "analyse-mislabelled",
        "analyse yoshida2008 {box}/bad-data/mislabelled.csv {box}/bad-data/second.csv --out {box}/report",
        "the protocol's label there is",
    ),
    (
        "analyse-header-only",
        "analyse yoshida2008 {box}/bad-data/header-only.csv {box}/bad-data/second.csv --out {box}/report",
        "header-only.csv: the session holds no trials",
    ),
    (
        "analyse-aborted",
        "analyse yoshida2008 {box}/bad-data/aborted.csv {box}/bad-data/second.csv --out {box}/report",
        "aborted.csv: the session did not complete (aborted)",
    ),
    (
        "analyse-sidecar",
        "analyse yoshida2008 {box}/bad-data/second.json --out {box}/report",
        "second.json: session data are CSV files",
    ),
    (
        "analyse-missing",
        "analyse yoshida2008 {box}/bad-data/none.csv --out {box}/report",
        "none.csv: no such file",
    ),
    (
        "analyse-out-file",
        "analyse yoshida2008 {box}/bad-data/second.csv --out {box}/afile.txt",
        "afile.txt is a file",
    ),
    (
        "analyse-out-foreign",
        "analyse yoshida2008 {box}/bad-data/second.csv --out {box}/report-here",
        "report-here holds files that are not an earlier report",
    ),
    (
        "analyse-stimuli",
        "analyse yoshida2008 {box}/bad-data/second.csv --out {box}/report --stimuli {box}/foreign",
        "--stimuli",
    ),
    (
        "render-option-of-another-model",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --model gaussian --pupil-mm 3",
        "--pupil-mm: not an option of --model gaussian",
    ),
    (
        "render-aperture-not-an-image",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --model wave --aperture-image "
        "{box}/afile.txt --aperture-spacing-mm 0.01",
        "afile.txt: not an image",
    ),
    (
        "psf-tiny-pixels",
        "psf --out {box}/k.png --pixel-deg 1e-300 --size 11 --model gaussian",
        "--pixel-deg: 1e-300",
    ),
    (
        "render-tiny-sigma",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --model gaussian --sigma-deg 1e-300",
        "--sigma-deg: 1e-300",
    ),
    (
        "render-many-particles",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --model wave --particles 100000000",
        "--particles: 100000000",
    ),
    (
        "render-many-sides",
        "render {box}/good.exr {box}/out.exr --pixel-deg 0.02 --model wave --diaphragm-sides 100000",
        "--diaphragm-sides: 100000",
    ),
    (
        "render-y-and-rgb",
        "render {box}/y-and-rgb.exr {box}/out.exr --pixel-deg 0.02",
        "both a Y channel and R, G, B",
    ),
    (
        "run-participant-and-count",
        "run luidolt2020 --simulate --participant P9 --participants 3 --out {box}/sim-data",
        "--participants 3 with --participant P9",
    ),
    # demo, check-display, bench, docs
    ("demo-participants", "demo --out {box}/demo --participants 0", "--participants: 0"),
    (
        "demo-foreign",
        "demo --protocol luidolt2020 --out {box}/foreign",
        "foreign holds files that are not an earlier demo folder",
    ),
    ("demo-file", "demo --out {box}/afile.txt", "afile.txt is a file"),
    (
        "check-display-frames",
        "check-display spencer1995 --frames 0 --out {box}/d.json",
        "--frames: 0",
    ),
    ("check-display-no-out", "check-display spencer1995", "give --out FILE"),
    (
        "check-display-txt",
        "check-display spencer1995 --out {box}/d.txt",
        "display check must be named .json",
    ),
    ("bench-repeats", "bench --repeats 0 --out {box}/bench", "--repeats: 0"),
    ("bench-only", "bench --only nothing --out {box}/bench", "nothing"),
    ("bench-acuity-only", "bench --acuity --only yoshida2008 --out {box}/bench", "yoshida2008"),
    ("bench-acuity-large", "bench --acuity --large --out {box}/bench", "--large"),
    ("bench-live-only", "bench --live --only yoshida2008 --out {box}/bench", "yoshida2008"),
    ("bench-live-acuity", "bench --live --acuity --out {box}/bench", "--acuity"),
    ("bench-acuity-foreign", "bench --acuity --out {box}/foreign", "foreign is a folder"),
    (
        "bench-foreign",
        "bench --only street_256 --out {box}/foreign",
        "foreign is a folder with files",
    ),
    ("docs-file", "docs --out {box}/afile.txt", "afile.txt is a file"),
    # power
    (
        "power-participants-1",
        "power luidolt2020 --participants 4 1 --out {box}/power",
        "--participants: 1 must be a whole number from 2 to 999",
    ),
    (
        "power-participants-huge",
        "power luidolt2020 --participants 1000 --out {box}/power",
        "--participants: 1000",
    ),
    (
        "power-participants-text",
        "power luidolt2020 --participants six --out {box}/power",
        "--participants: 'six' is not a whole number",
    ),
    (
        "power-no-participants",
        "power luidolt2020 --out {box}/power",
        "the following arguments are required: --participants",
    ),
    (
        "power-replications-0",
        "power luidolt2020 --participants 4 --replications 0 --out {box}/power",
        "--replications: 0",
    ),
    (
        "power-alpha-1",
        "power luidolt2020 --participants 4 --alpha 1 --out {box}/power",
        "--alpha: 1 must be a number in (0, 1)",
    ),
    (
        "power-alpha-nan",
        "power luidolt2020 --participants 4 --alpha nan --out {box}/power",
        "--alpha: nan",
    ),
    (
        "power-target-0",
        "power luidolt2020 --participants 4 --target-power 0 --out {box}/power",
        "--target-power: 0",
    ),
    (
        "power-correction",
        "power luidolt2020 --participants 4 --correction GG --out {box}/power",
        "--correction: invalid choice: 'GG'",
    ),
    (
        "power-seed",
        "power luidolt2020 --participants 4 --seed -1 --out {box}/power",
        "--seed: -1",
    ),
    (
        "power-workers-negative",
        "power luidolt2020 --participants 4 --workers -1 --out {box}/power",
        "--workers: -1",
    ),
    (
        "power-workers-and-scheduler",
        "power luidolt2020 --participants 4 --workers 2 --scheduler tcp://127.0.0.1:1 --out {box}/power",
        "--scheduler: not allowed with argument --workers",
    ),
    (
        "power-scheduler-address",
        "power luidolt2020 --participants 4 --scheduler nowhere --out {box}/power",
        "--scheduler: 'nowhere' is not a Dask scheduler's address",
    ),
    (
        "power-scheduler-protocol",
        "power luidolt2020 --participants 4 --scheduler pigeon://host:1 --out {box}/power",
        "unknown protocol 'pigeon'",
    ),
    (
        "power-unknown-study",
        "power yoshida2009 --participants 4 --out {box}/power",
        "yoshida2009",
    ),
    (
        "power-out-file",
        "power luidolt2020 --participants 4 --out {box}/afile.txt",
        "afile.txt is a file",
    ),
    (
        "power-out-foreign",
        "power luidolt2020 --participants 4 --out {box}/foreign",
        "foreign is a folder with files glarelab power did not write",
    ),
    (
        "power-out-other-run",
        "power luidolt2020 --participants 3 --replications 1 --seed 2 --workers 0 --out {box}/power-done",
        "seed 1 then, 2 now",
    ),
    (
        "power-stimuli-foreign",
        "power yoshida2008 --participants 4 --stimuli {box}/foreign --out {box}/power",
        "--stimuli: {box}/foreign is not an intact stimulus set",
    ),
    (
        "power-stimuli-rating",
        "power luidolt2020 --participants 4 --stimuli {box}/set --out {box}/power",
        "--stimuli: the luidolt2020 protocol shows no images",
    ),
    (
        "power-stimuli-other-protocol",
        "power spencer1995 --participants 4 --stimuli {box}/set --out {box}/power",
        "built from another protocol than spencer1995's",
    ),
    (
        "power-scratch",
        "power luidolt2020 --participants 4 --scratch {box}/none --out {box}/power",
        "--scratch: {box}/none: no such folder",
    ),
    # sweep
    (
        "sweep-no-values",
        "sweep yoshida2008 --set stimulus.disk_deg --out {box}/sweep",
        "--set: 'stimulus.disk_deg': give KEY=V1,V2",
    ),
    (
        "sweep-bad-toml",
        "sweep yoshida2008 --set stimulus.disk_deg=[0.2, --out {box}/sweep",
        "are not TOML values",
    ),
    (
        "sweep-no-table",
        "sweep yoshida2008 --set glare.methods.nope.labels=1 --out {box}/sweep",
        "--set glare.methods.nope.labels: glare.methods has no table named 'nope'",
    ),
    (
        "sweep-position",
        "sweep yoshida2008 --set glare.methods[7].labels=1 --out {box}/sweep",
        "glare.methods has 2 entries, positions 0-1; got 7",
    ),
    (
        "sweep-invalid-point",
        "sweep yoshida2008 --set stimulus.disk_deg=0.2,99 --out {box}/sweep",
        "stimulus.disk_deg = 99: stimulus.disk_deg = 99.0: must be float, in [0.01, 10] deg",
    ),
    (
        "sweep-unknown-key",
        "sweep yoshida2008 --set stimulus.disk_dag=0.2 --out {box}/sweep",
        "stimulus.disk_dag",
    ),
    (
        "sweep-repeated-key",
        "sweep yoshida2008 --set stimulus.disk_deg=0.2 --set stimulus.disk_deg=0.3 --out {box}/sweep",
        "each key once; repeated stimulus.disk_deg",
    ),
    (
        "sweep-too-many-points",
        "sweep yoshida2008 --set study.seed="
        + ",".join(map(str, range(40)))
        + " --set stimulus.disk_deg="
        + ",".join(f"0.{i:02d}" for i in range(10, 40))
        + " --out {box}/sweep",
        "the grid has 1200 points (40 × 30); a sweep builds at most 1000",
    ),
    (
        "sweep-simulate-1",
        "sweep yoshida2008 --set stimulus.disk_deg=0.2 --simulate 1 --out {box}/sweep",
        "--simulate: 1: the analysis needs at least 2 simulated observers",
    ),
    (
        "sweep-rating-no-simulate",
        "sweep luidolt2020 --set study.seed=1,2 --out {box}/sweep",
        "shows no images: there are no stimulus sets to build; add --simulate N",
    ),
    (
        "sweep-seed",
        "sweep yoshida2008 --set stimulus.disk_deg=0.2 --seed x --out {box}/sweep",
        "--seed: 'x' is not a whole number",
    ),
    (
        "sweep-workers",
        "sweep yoshida2008 --set stimulus.disk_deg=0.2 --workers 999 --out {box}/sweep",
        "--workers: 999 must be a whole number from 0 to 256",
    ),
    (
        "sweep-unknown-study",
        "sweep yoshida2009 --set stimulus.disk_deg=0.2 --out {box}/sweep",
        "yoshida2009",
    ),
    (
        "sweep-out-file",
        "sweep yoshida2008 --set stimulus.disk_deg=0.2 --out {box}/afile.txt",
        "afile.txt is a file",
    ),
    (
        "sweep-out-foreign",
        "sweep yoshida2008 --set stimulus.disk_deg=0.2 --out {box}/foreign",
        "foreign is a folder with files glarelab sweep did not write",
    ),
    ("cache-unknown-action", "cache purge", "invalid choice: 'purge'"),
    (
        "export-monitor-folder",
        "calibrate export-monitor {box}/8bit.json --monitor lab --monitor-folder {box}/nowhere",
        "--monitor-folder {box}/nowhere: no such folder",
    ),
    (
        "stimuli-monitor-unknown",
        "stimuli build spencer1995 --monitor nowhere --monitor-folder {box} --out {box}/set",
        "--monitor 'nowhere': no such monitor in Monitor Center's folder",
    ),
    (
        "run-monitor-folder-alone",
        "run spencer1995 --participant P1 --monitor-folder {box} --out {box}/data",
        "--monitor-folder needs --monitor NAME",
    ),
    ("examples-into-a-file", "examples {box}/afile.txt", "afile.txt"),
    (
        "import-psychopy-missing",
        "import-psychopy yoshida2008 {box}/missing.csv --out {box}/imported",
        "missing.csv",
    ),
]


def test_the_catalogue_covers_every_command():
    from glarelab.cli import _parser

    commands = {case[1].split()[0] for case in CASES}
    subparsers = next(a for a in _parser()._actions if a.dest == "command")
    assert commands >= set(subparsers.choices), set(subparsers.choices)
    assert len(CASES) >= 60


@pytest.mark.parametrize(("command", "culprit"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_a_bad_input_is_refused_by_name_and_changes_nothing(sandbox, capsys, command, culprit):
    import glob

    argv = []
    for word in command.format(box=sandbox).split():
        matches = sorted(glob.glob(word)) if "*" in word else [word]
        argv += matches
    before = snapshot(sandbox)
    status, err = refused(argv, capsys)
    assert status not in (0, None), err
    assert "Traceback" not in err and "please report" not in err, err
    assert culprit.format(box=sandbox) in err, err
    assert err.count("usage:") == 0, err  # one line, not the usage text
    after = snapshot(sandbox)
    assert after == before, {k for k in before.keys() ^ after.keys()} or "a file changed"


def test_a_label_of_more_than_one_line_is_refused(sandbox, capsys):
    before = snapshot(sandbox)
    for command in ("fit", "measure"):
        argv = ["calibrate", command, f"{sandbox}/readings-good.csv", "--label", "lab 2\nPR-655"]
        if command == "measure":
            argv[2:3] = ["--simulate", "400", "0.5", "2.2"]
        status, err = refused([*argv, "--out", f"{sandbox}/c.json"], capsys)
        assert status == 2 and "--label: 'lab 2\\nPR-655' holds '\\n': must be one line" in err
    assert snapshot(sandbox) == before


def test_a_size_beyond_memory_is_refused_before_allocating(sandbox, capsys, monkeypatch):
    import glarelab.commands.common as common

    monkeypatch.setattr(common, "available_memory", lambda: 2**19)
    before = snapshot(sandbox)
    status, err = refused(
        ["render", f"{sandbox}/good.exr", f"{sandbox}/out.exr", "--pixel-deg", "0.02"], capsys
    )
    assert status == 2 and "needs about" in err and "GiB are available" in err, err
    status, err = refused(["psf", "--out", f"{sandbox}/k.png", "--size", "16385"], capsys)
    assert status == 2 and "a 16385² kernel needs about" in err, err
    for command in ("power", "sweep"):  # a local cluster's workers
        status, err = refused(
            [command, "yoshida2008", "--workers", "2", "--out", f"{sandbox}/{command}"]
            + (["--participants", "4"] if command == "power" else ["--set", "study.seed=1"]),
            capsys,
        )
        assert status == 2 and "--workers 2 needs about" in err, err
    assert snapshot(sandbox) == before


def test_a_bug_prints_its_traceback_and_asks_for_a_report(monkeypatch, capsys):
    import glarelab.commands.protocol as protocol_commands

    def broken(args):
        raise KeyError("an internal slip")

    monkeypatch.setattr(protocol_commands, "_protocol_check", broken)
    status, err = refused(["protocol", "check", "yoshida2008"], capsys)
    assert status == 70
    assert "Traceback" in err and "KeyError: 'an internal slip'" in err
    assert "a bug in glarelab: please report it" in err


# the cases that destroyed data or tricked a stimulus set


def test_the_demo_never_deletes_a_participants_data(sandbox, tmp_path, capsys):
    lab = tmp_path / "lab"
    shutil.copytree(sandbox / "data", lab / "data")
    for sidecar in (lab / "data").glob("*.json"):  # real participants, not simulated
        record = json.loads(sidecar.read_text())
        sidecar.write_text(json.dumps(record | {"simulated": False}))
    before = snapshot(lab)
    status, err = refused(["demo", "--protocol", "luidolt2020", "--out", str(lab)], capsys)
    assert status == 2 and "not an earlier demo folder" in err
    assert snapshot(lab) == before
    # a folder the demo made, where a real session has been recorded since
    demo = tmp_path / "demo"
    assert (
        main(["demo", "--protocol", "luidolt2020", "--out", str(demo), "--participants", "2"]) == 0
    )
    capsys.readouterr()
    real = next((lab / "data").glob("sim01_luidolt2020_s1_*.csv"))
    for path in real.parent.glob(real.stem + ".*"):
        shutil.copy(path, demo / "data" / path.name.replace("sim01", "P07"))
    before = snapshot(demo)
    status, err = refused(["demo", "--protocol", "luidolt2020", "--out", str(demo)], capsys)
    assert status == 2 and "P07_luidolt2020_s1_" in err, err
    assert snapshot(demo) == before
    # the demo's own folder, as it left it, is replaced
    shutil.rmtree(demo / "data")
    assert (
        main(["demo", "--protocol", "luidolt2020", "--out", str(demo), "--participants", "1"]) == 0
    )
    assert len(list((demo / "data").glob("*.csv"))) == 1


def _lab_folder(root: Path, *files: str) -> Path:
    """A folder of someone else's files, named relative to it."""
    for name in files:
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(f"{name}: someone else's\n")
    return root


@pytest.mark.parametrize(
    ("command", "files"),
    [
        # a folder holding a file of the output's name is not therefore an earlier output
        ("analyse yoshida2008 {data} --out {lab}", ["report.html", "chapter1.tex"]),
        ("stimuli build yoshida2008 --out {lab}", ["manifest.json", "src/app.js"]),
        ("demo --protocol luidolt2020 --out {lab}", ["report/report.html", "data/P01.csv"]),
        ("docs --out {lab}", ["protocols.md"]),
        ("looks --out {lab}", ["manifest.json"]),
        ("gallery --out {lab} --size 33", ["wave_daylight_pupil.png"]),
    ],
)
def test_no_command_overwrites_files_it_did_not_write(sandbox, tmp_path, capsys, command, files):
    lab = _lab_folder(tmp_path / "lab", *files)
    data = sorted(str(p) for p in (sandbox / "data").glob("*_yoshida2008_*.csv"))
    argv = command.format(lab=lab, data=" ".join(data)).split()
    before = snapshot(lab)
    status, err = refused(argv, capsys)
    assert status == 2 and "Traceback" not in err, err
    assert any(name.split("/")[-1] in err for name in files) or str(lab) in err, err
    assert snapshot(lab) == before


def test_an_analysis_never_replaces_the_folder_of_its_inputs(sandbox, tmp_path, capsys):
    data = tmp_path / "study"
    shutil.copytree(sandbox / "data", data / "data")
    csvs = sorted(str(p) for p in (data / "data").glob("*_yoshida2008_*.csv"))
    before = snapshot(data)
    for out in (data, data / "data"):
        status, err = refused(["analyse", "yoshida2008", *csvs, "--out", str(out)], capsys)
        assert status == 2 and "replaces whole" in err, err
        assert snapshot(data) == before
    # its own earlier report is replaced whole, and a note added to it since is refused
    report = tmp_path / "report"
    assert main(["analyse", "yoshida2008", *csvs, "--out", str(report)]) == 0
    assert main(["analyse", "yoshida2008", *csvs, "--out", str(report)]) == 0
    (report / "notes.txt").write_text("my notes\n")
    capsys.readouterr()
    status, err = refused(["analyse", "yoshida2008", *csvs, "--out", str(report)], capsys)
    assert status == 2 and "notes.txt" in err, err
    assert (report / "notes.txt").read_text() == "my notes\n"


def test_the_demo_refuses_a_session_without_sidecar_and_a_linked_data_folder(
    sandbox, tmp_path, capsys
):
    demo = tmp_path / "demo"
    argv = ["demo", "--protocol", "luidolt2020", "--out", str(demo), "--participants", "1"]
    assert main(argv) == 0
    capsys.readouterr()
    (demo / "data" / "P01_luidolt2020_s1_2026-01-01_0900.csv").write_text("study\nluidolt2020\n")
    before = snapshot(demo)
    status, err = refused(argv, capsys)
    assert status == 2 and "P01_luidolt2020" in err, err
    assert snapshot(demo) == before
    # a data folder that is a link to a lab's data
    lab = _lab_folder(tmp_path / "lab", "P02_luidolt2020_s1_2026-01-01_0900.csv")
    linked = tmp_path / "linked"
    linked.mkdir()
    (linked / "data").symlink_to(lab)
    status, err = refused(["demo", "--protocol", "luidolt2020", "--out", str(linked)], capsys)
    assert status == 2 and "data" in err, err
    assert sorted(p.name for p in lab.iterdir()) == ["P02_luidolt2020_s1_2026-01-01_0900.csv"]


def test_render_never_writes_over_its_input_through_a_hard_link(sandbox, tmp_path, capsys):
    source = tmp_path / "scene.exr"
    shutil.copy(sandbox / "good.exr", source)
    os.link(source, tmp_path / "linked.exr")
    before = snapshot(tmp_path)
    status, err = refused(
        ["render", str(source), str(tmp_path / "linked.exr"), "--pixel-deg", "0.02"], capsys
    )
    assert status == 2 and "also an input" in err, err
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize(
    ("labels", "problem"),
    [
        ('["A", "A", "C", "D", "E", "F"]', "repeats 'A'"),
        ('["A", "a", "C", "D", "E", "F"]', "repeats 'A', 'a'"),
        ('["../../../escaped", "B", "C", "D", "E", "F"]', "'../../../escaped'"),
        ('["A", "B", "C", "D", "E", "F/G"]', "'F/G'"),
        ('["A", "B", "C", "D", "E", ""]', "''"),
    ],
)
def test_level_labels_must_be_unique_safe_file_name_tokens(tmp_path, capsys, labels, problem):
    text = (PROTOCOLS / "yoshida2008.toml").read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(
        text.replace('labels = ["A", "B", "C", "D", "E", "F"]', f"labels = {labels}", 1)
    )
    status, err = refused(["stimuli", "build", str(bad), "--out", str(tmp_path / "set")], capsys)
    assert status == 2 and "labels" in err and problem in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]
    assert not (tmp_path.parent / "escaped").exists()


def _copy_set(sandbox: Path, tmp_path: Path) -> Path:
    folder = tmp_path / "set"
    shutil.copytree(sandbox / "set", folder)
    assert verify_stimulus_set(folder) == []
    return folder


def test_verify_finds_a_swapped_image_behind_an_emptied_manifest(sandbox, tmp_path, capsys):
    folder = _copy_set(sandbox, tmp_path)
    manifest = json.loads((folder / "manifest.json").read_text())
    (folder / "manifest.json").write_text(json.dumps(manifest | {"files": {}}))
    shutil.copy(folder / "reference_vos_c.exr", folder / "reference_vos_d.exr")
    status, err = refused(["stimuli", "verify", str(folder)], capsys)
    assert status == 1 and "must list the set's files" in err


def test_verify_refuses_a_manifest_that_is_not_an_object(sandbox, tmp_path, capsys):
    folder = _copy_set(sandbox, tmp_path)
    (folder / "manifest.json").write_text("[]")
    status, err = refused(["stimuli", "verify", str(folder)], capsys)
    assert status == 1 and "must be a JSON object; it is a list" in err
    (folder / "manifest.json").write_text("{not json")
    status, err = refused(["stimuli", "verify", str(folder)], capsys)
    assert status == 1 and "not valid JSON" in err


def test_verify_names_every_missing_extra_and_changed_file(sandbox, tmp_path):
    folder = _copy_set(sandbox, tmp_path)
    (folder / "reference_vos_a.png").unlink()
    (folder / "added.exr").write_bytes(b"x")
    data = bytearray((folder / "reference_vos_b.exr").read_bytes())
    data[-5] ^= 0xFF
    (folder / "reference_vos_b.exr").write_bytes(bytes(data))
    problems = verify_stimulus_set(folder)
    assert "reference_vos_a.png: missing" in problems
    assert "added.exr: not in the manifest (added after the build?)" in problems
    assert "reference_vos_b.exr: changed (sha256 differs from the manifest)" in problems
    assert len(problems) == 3


def test_a_rebuild_replaces_the_set_whole_and_a_failed_one_keeps_it(sandbox, tmp_path, capsys):
    folder = _copy_set(sandbox, tmp_path)
    (folder / "stale.exr").write_bytes(b"left from an older build")
    record_files(folder, "stimulus set")  # as an older build of another protocol would list it
    manifest = json.loads((folder / "manifest.json").read_text())
    assert main(["stimuli", "build", "yoshida2008", "--out", str(folder)]) == 0
    assert not (folder / "stale.exr").exists() and verify_stimulus_set(folder) == []
    assert json.loads((folder / "manifest.json").read_text())["files"] == manifest["files"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set"]  # no staging folder left


def test_a_sidecar_that_contradicts_its_csv_is_refused(sandbox, tmp_path, capsys):
    source = next((sandbox / "data").glob("sim01_yoshida2008_*.csv"))
    for change, named in [
        ({"participant": "P77"}, "participant 'P77'"),
        ({"study": "spencer1995"}, "study 'spencer1995'"),
        ({"simulated": "no"}, 'simulated is "no"; must be true or false'),
        ({"session": 2}, "session 2"),
    ]:
        csv = shutil.copy(source, tmp_path / source.name)
        sidecar = json.loads(source.with_suffix(".json").read_text())
        Path(csv).with_suffix(".json").write_text(json.dumps(sidecar | change))
        status, err = refused(
            ["analyse", "yoshida2008", str(csv), "--out", str(tmp_path / "report")], capsys
        )
        assert status == 2 and named in err, err
        assert not (tmp_path / "report").exists()


def test_a_csv_without_sidecar_is_listed_with_its_origin_unknown(sandbox, tmp_path, capsys):
    csvs = []
    for source in sorted((sandbox / "data").glob("sim0*_yoshida2008_*.csv")):
        csvs.append(shutil.copy(source, tmp_path / source.name))
        if len(csvs) > 1:
            shutil.copy(source.with_suffix(".json"), tmp_path / source.with_suffix(".json").name)
    argv = ["analyse", "yoshida2008", *map(str, csvs), "--out", str(tmp_path / "r")]
    status, err = refused(argv, capsys)
    assert status == 2 and f"{csvs[0]}: no sidecar" in err and "--include-no-sidecar" in err, err
    assert main([*argv, "--include-no-sidecar"]) == 0
    origin = json.loads((tmp_path / "r" / "provenance.json").read_text())
    assert origin["simulated"] == "mixed"
    first = next(s for s in origin["sessions"] if s["file"] == Path(csvs[0]).name)
    assert first["status"] == "no sidecar" and first["simulated"] is None
    assert "no sidecar" in (tmp_path / "r" / "report.html").read_text()


def test_ctrl_c_stops_a_batch_of_simulated_participants(tmp_path):
    command = [sys.executable, "-m", "glarelab", "run", "luidolt2020", "--simulate"]
    command += ["--participants", "3", "--trial-delay-ms", "1000", "--out", str(tmp_path)]
    batch = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120

    def rows() -> int:  # sim01's trials on disk so far
        found = list(tmp_path.glob("sim01_*.csv"))
        return len(found[0].read_text().splitlines()) - 1 if found else 0

    while rows() < 1 and time.monotonic() < deadline:  # within sim01's session
        time.sleep(0.05)
    batch.send_signal(signal.SIGINT)
    _, err = batch.communicate(timeout=120)
    assert batch.returncode == 3, err
    assert "Traceback" not in err and "not run" in err, err
    assert not list(tmp_path.glob("sim02_*"))


def test_spreadsheet_text_files_are_read_or_named(sandbox, tmp_path, capsys):
    source = next((sandbox / "data").glob("sim01_yoshida2008_*.csv"))
    sidecar = source.with_suffix(".json")
    # Excel's "CSV UTF-8" starts with a byte-order mark: read as any CSV
    bom = tmp_path / "bom" / source.name
    bom.parent.mkdir()
    bom.write_bytes(b"\xef\xbb\xbf" + source.read_bytes())
    shutil.copy(sidecar, bom.with_suffix(".json"))
    assert main(["analyse", "yoshida2008", str(bom), "--out", str(tmp_path / "r")]) == 0
    capsys.readouterr()
    # a file in another encoding, and a cell beyond the csv module's limit, are named
    for name, content in [
        ("latin1", source.read_bytes().replace(b"sim01", b"sim\xe901", 1)),
        ("long", source.read_bytes() + b'"' + b"x" * 200_000 + b'"\n'),
    ]:
        bad = tmp_path / name / source.name
        bad.parent.mkdir()
        bad.write_bytes(content)
        shutil.copy(sidecar, bad.with_suffix(".json"))
        status, err = refused(
            ["analyse", "yoshida2008", str(bad), "--out", str(tmp_path / name / "r")], capsys
        )
        assert status == 2 and str(bad) in err and "Traceback" not in err, err
    # a protocol and photometer readings saved with a byte-order mark
    protocol = tmp_path / "bom.toml"
    protocol.write_bytes(b"\xef\xbb\xbf" + (PROTOCOLS / "luidolt2020.toml").read_bytes())
    assert main(["protocol", "check", str(protocol)]) == 0
    readings = tmp_path / "readings.csv"
    readings.write_bytes(
        b"\xef\xbb\xbf" + (ROOT / "calibrations" / "example-readings.csv").read_bytes()
    )
    assert main(["calibrate", "fit", str(readings), "--out", str(tmp_path / "c.json")]) == 0


def test_absurd_readings_and_repeated_follow_up_names_are_refused(tmp_path, capsys):
    readings = tmp_path / "readings.csv"
    readings.write_text("code,luminance_cd_m2\n0,0.5\n300,50\n600,200\n1023,1e308\n")
    status, err = refused(
        [
            "calibrate",
            "fit",
            str(readings),
            "--bit-depth",
            "10",
            "--out",
            str(tmp_path / "c.json"),
        ],
        capsys,
    )
    assert status == 2 and "line 5: code 1023" in err and "1e308;" in err, err  # as written
    text = (PROTOCOLS / "yoshida2008.toml").read_text()
    assert text.count("[[analysis.followups]]") >= 2
    start = text.index("[[analysis.followups]]")
    name_line = next(line for line in text[start:].splitlines() if line.startswith("name"))
    second = text.index(name_line, start) + len(name_line)
    second_name = next(line for line in text[second:].splitlines() if line.startswith("name"))
    twice = tmp_path / "twice.toml"
    twice.write_text(text[:second] + text[second:].replace(second_name, name_line, 1))
    status, err = refused(["protocol", "check", str(twice)], capsys)
    assert status == 2 and "used twice" in err, err


def test_a_comment_never_runs_as_a_spreadsheet_formula(sandbox, tmp_path):
    source = next((sandbox / "data").glob("sim01_luidolt2020_*.csv"))
    frame = pd.read_csv(source, keep_default_na=False)
    frame.loc[0, "comment"] = '=HYPERLINK("http://example.org","click")'
    frame.loc[1, "comment"] = "-2+3+cmd|' /C calc'!A0"  # OWASP's: "-" and a digit run too
    frame.loc[2, "comment"] = "-0.5"
    csv = tmp_path / source.name
    frame.to_csv(csv, index=False)
    shutil.copy(source.with_suffix(".json"), csv.with_suffix(".json"))
    reseal(csv)  # as the session would have written the participant's comments
    assert main(["analyse", "luidolt2020", str(csv), "--out", str(tmp_path / "r")]) == 0
    comments = pd.read_csv(tmp_path / "r" / "comments.csv", keep_default_na=False)
    assert '\'=HYPERLINK("http://example.org","click")' in set(comments["comment"])
    assert "'-2+3+cmd|' /C calc'!A0" in set(comments["comment"])
    assert "-0.5" in set(comments["comment"])  # a number's sign stays
    assert pd.read_csv(csv, keep_default_na=False).loc[0, "comment"].startswith("=HYPERLINK")


def test_verify_finds_an_edited_manifest(sandbox, tmp_path, capsys):
    folder = _copy_set(sandbox, tmp_path)
    original = (folder / "manifest.json").read_text()
    manifest = json.loads(original)
    manifest["protocol"]["display"]["max_cd_m2"] = 1000.0  # the hash kept
    (folder / "manifest.json").write_text(json.dumps(manifest))
    assert any("protocol_sha256" in p for p in verify_stimulus_set(folder))
    manifest = json.loads(original)
    first, second = sorted(manifest["images"])[:2]
    images = manifest["images"]
    images[first]["files"], images[second]["files"] = (
        images[second]["files"],
        images[first]["files"],
    )
    (folder / "manifest.json").write_text(json.dumps(manifest))
    problems = verify_stimulus_set(folder)
    assert any(f"image {first} points at" in p for p in problems), problems
    status, err = refused(["stimuli", "verify", str(folder)], capsys)
    assert status == 1, err


@pytest.mark.parametrize(
    ("old", "new", "named"),
    [
        ("distance_m = 1.0", "distance_m = 20.0", "more than the display's 2048 × 1536"),
        ("supersample = 2 ", "supersample = 8 ", None),  # fits: 271 px × 8
        (
            "target_start_cd_m2 = [100.0, 400.0]",
            "target_start_cd_m2 = [400.0, 100.0]",
            "the darker target must start below",
        ),
    ],
)
def test_a_protocol_whose_stimuli_cannot_be_shown_is_refused(tmp_path, capsys, old, new, named):
    text = (PROTOCOLS / "yoshida2008.toml").read_text()
    assert old in text
    changed = tmp_path / "changed.toml"
    changed.write_text(text.replace(old, new, 1))
    status, err = refused(["protocol", "check", str(changed)], capsys)
    if named is None:
        assert status == 0, err
    else:
        assert status == 2 and named in err, err


def test_one_session_in_two_files_is_one_line(sandbox, tmp_path, capsys):
    source = next((sandbox / "data").glob("sim01_yoshida2008_*.csv"))
    copy = tmp_path / source.name  # a copy in another folder (a renamed one names its name)
    shutil.copy(source, copy)
    shutil.copy(source.with_suffix(".json"), copy.with_suffix(".json"))
    status, err = refused(
        ["analyse", "yoshida2008", str(source), str(copy), "--out", str(tmp_path / "r")], capsys
    )
    assert status == 2 and "participant sim01: the same session in 2 files" in err, err
    assert "duplicated trial" not in err, err


def test_a_link_loop_met_anywhere_else_is_named_not_a_bug():
    from glarelab.cli import _refusal

    # pathlib's resolve() up to Python 3.12, for a path no command checked first
    message = _refusal(RuntimeError("Symlink loop from '/data/loop/c.json'"))
    assert (
        message
        == "'/data/loop/c.json': a loop of symbolic links on the way; give a path without one"
    )


@pytest.mark.parametrize("listing", ["with contents", "of an earlier version"])
def test_a_rebuild_refuses_a_set_whose_readme_a_lab_edited(listing, sandbox, tmp_path, capsys):
    """Issue 38 item 3 (attack case b007): a note added to the set's README.md is kept and
    the rebuild refused, naming the file; for a set whose listing records no contents (an
    earlier version's), the manifest's sha256 tells."""
    folder = _copy_set(sandbox, tmp_path)
    if listing == "of an earlier version":
        kept = json.loads((folder / ".glarelab-files.json").read_text())
        (folder / ".glarelab-files.json").write_text(json.dumps({"files": kept["files"]}))
    with (folder / "README.md").open("a") as readme:
        readme.write("LAB NOTE\n")
    before = snapshot(folder)
    status, err = refused(["stimuli", "build", "yoshida2008", "--out", str(folder)], capsys)
    assert status == 2 and "edited since glarelab wrote them (README.md)" in err
    assert "--out" in err.strip().splitlines()[-1]
    assert snapshot(folder) == before
