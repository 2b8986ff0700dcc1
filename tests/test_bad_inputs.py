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
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from experiments.session import SimulatedFrontend, make_observer, run_session
from glarelab.cli import main
from protocols import load_protocol
from stimuli.exr import write_exr
from stimuli.stimulus_set import cached_stimulus_set, verify_stimulus_set

ROOT = Path(__file__).parents[1]
PROTOCOLS = ROOT / "protocols"


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
    (box / "afile.txt").write_text("a file\n")
    (box / "foreign").mkdir()
    (box / "foreign" / "notes.txt").write_text("someone else's\n")
    # calibrations
    (box / "calibration-text.json").write_text("not json\n")
    (box / "calibration-list.json").write_text("[1, 2, 3]\n")
    shutil.copy(ROOT / "calibrations" / "SYNTHETIC-spencer1995-100cd-8bit.json", box / "8bit.json")
    (box / "readings-down.csv").write_text(
        "code,luminance_cd_m2\n0,0.5\n300,50\n600,40\n1023,400\n"
    )
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
    _variant(
        first, bad / "mislabelled.csv", set_cell("level", "B" if level != "B" else "C", main_row)
    )
    _variant(first, bad / "header-only.csv", lambda frame: frame.iloc[:0])
    aborted = _variant(first, bad / "aborted.csv", lambda frame: frame.iloc[:-3])
    sidecar = json.loads(aborted.with_suffix(".json").read_text())
    aborted.with_suffix(".json").write_text(json.dumps(sidecar | {"status": "aborted"}))
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
    # stimuli
    ("build-unknown", "stimuli build yoshida2009 --out {box}/newset", "yoshida2009"),
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
        "foreign holds files but no stimulus set",
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
    ("verify-no-manifest", "stimuli verify {box}/foreign", "manifest.json: missing"),
    # protocol
    ("protocol-missing-file", "protocol check {box}/none.toml", "none.toml"),
    ("protocol-scale-10", "protocol check {box}/scale10.toml", "questionnaire.scale_max"),
    ("protocol-syntax", "protocol check {box}/syntax.toml", "syntax.toml"),
    ("protocol-keys-unknown", "protocol keys nonsense", "nonsense"),
    # calibrate
    ("fit-missing", "calibrate fit {box}/none.csv --out {box}/c.json", "none.csv"),
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
        "run-scripted-none",
        "run luidolt2020 --participant P1 --scripted-keys {box}/none.txt --out {box}/runs",
        "none.txt: no such file",
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
        "report-here holds files but no report",
    ),
    (
        "analyse-stimuli",
        "analyse yoshida2008 {box}/bad-data/second.csv --out {box}/report --stimuli {box}/foreign",
        "--stimuli",
    ),
    # demo, check-display, bench, docs
    ("demo-participants", "demo --out {box}/demo --participants 0", "--participants: 0"),
    (
        "demo-foreign",
        "demo --protocol luidolt2020 --out {box}/foreign",
        "foreign holds files the demo did not write",
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
    assert status == 2 and "did not write" in err
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
    assert status == 2 and "is not a simulated session" in err, err
    assert snapshot(demo) == before
    # the demo's own folder, as it left it, is replaced
    shutil.rmtree(demo / "data")
    assert (
        main(["demo", "--protocol", "luidolt2020", "--out", str(demo), "--participants", "1"]) == 0
    )
    assert len(list((demo / "data").glob("*.csv"))) == 1


@pytest.mark.parametrize(
    ("labels", "problem"),
    [
        ('["A", "A", "C", "D", "E", "F"]', "repeats 'A'"),
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
    manifest = json.loads((folder / "manifest.json").read_text())
    assert main(["stimuli", "build", "yoshida2008", "--out", str(folder)]) == 0
    assert not (folder / "stale.exr").exists() and verify_stimulus_set(folder) == []
    assert json.loads((folder / "manifest.json").read_text())["files"] == manifest["files"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["set"]  # no staging folder left
