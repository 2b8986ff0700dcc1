"""Inputs, stimulus sets and calibrations are never written over, edited calibrations are
refused, and the bad inputs that once ended in a traceback or passed silently are refused in
one line naming the culprit (exit 2), with nothing changed."""

from __future__ import annotations

import json
import os
import shutil
import signal
import struct
import subprocess
import sys
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from glarelab.cli import main
from glarelab.display.calibration import Calibration, fit_calibration, read_readings
from glarelab.files.folders import record_files
from glarelab.stimuli.exr import write_exr

ROOT = Path(__file__).parents[1]
READINGS = ROOT / "calibrations" / "example-readings.csv"
PYTHON = [sys.executable, "-m", "glarelab"]


def snapshot(root: Path) -> dict[str, tuple]:
    state = {}
    for folder, folders, files in os.walk(root):
        for name in folders + files:
            path = Path(folder) / name
            info = path.lstat()
            state[str(path.relative_to(root))] = (info.st_size, info.st_mtime_ns)
    return state


def refused(argv: list[str], capsys, root: Path, culprit: str) -> str:
    """``glarelab argv`` exits 2 with one line naming ``culprit`` and changes nothing."""
    before = snapshot(root)
    capsys.readouterr()
    try:
        status = main(argv)
    except SystemExit as stop:
        status = stop.code
    err = capsys.readouterr().err
    assert status == 2, err
    assert "Traceback" not in err
    assert culprit in err, err
    first, *more = [line for line in err.strip().splitlines() if not line.startswith("[glarelab]")]
    assert first.startswith("glarelab"), err
    assert all(line.startswith("  - ") for line in more), err  # a list of problems: one a line
    assert snapshot(root) == before
    return err


@pytest.fixture
def box(tmp_path) -> Path:
    image = np.full((32, 32), 1.0, np.float32)
    image[14:18, 14:18] = 1e4
    write_exr(tmp_path / "in.exr", image)
    Image.fromarray(np.full((16, 16), 255, np.uint8)).save(tmp_path / "aperture.png")
    return tmp_path


def test_psf_and_render_never_overwrite_their_aperture_image(box, capsys):
    aperture = str(box / "aperture.png")
    refused(["psf", "--out", aperture, "--aperture-image", aperture, "--size", "11",
             "--pixel-deg", "0.05", "--aperture-spacing-mm", "0.1"], capsys, box,
            "also an input")  # fmt: skip
    refused(["render", str(box / "in.exr"), str(box / "out.exr"), "--pixel-deg", "0.02",
             "--model", "wave", "--aperture-image", aperture, "--preview", aperture],
            capsys, box, "also an input")  # fmt: skip


def test_render_never_writes_through_a_link_or_over_a_foreign_file(box, capsys):
    elsewhere = box / "elsewhere.exr"
    elsewhere.write_bytes(b"someone's file")
    (box / "link.exr").symlink_to(elsewhere)
    render = ["render", str(box / "in.exr")]
    options = ["--pixel-deg", "0.02", "--model", "gaussian"]
    refused([*render, str(box / "link.exr"), *options], capsys, box, "symbolic link")
    refused([*render, str(elsewhere), *options], capsys, box, "glarelab did not write it")
    # --force replaces the link itself, never the file it points to
    assert main([*render, str(box / "link.exr"), *options, "--force"]) == 0
    assert elsewhere.read_bytes() == b"someone's file"
    assert not (box / "link.exr").is_symlink()
    # its own earlier output it replaces without --force
    assert main([*render, str(box / "own.exr"), *options]) == 0
    assert main([*render, str(box / "own.exr"), *options, "--sigma-deg", "0.5"]) == 0


def test_nothing_is_written_into_a_stimulus_set(box, capsys):
    stimuli = box / "set"
    stimuli.mkdir()
    (stimuli / "a.png").write_bytes(b"png")
    record_files(stimuli, "stimulus set")
    refused(["render", str(box / "in.exr"), str(stimuli / "a.exr"), "--pixel-deg", "0.02",
             "--model", "gaussian"], capsys, box, "inside the stimulus set")  # fmt: skip
    refused(["run", "luidolt2020", "--simulate", "--participants", "2", "--out",
             str(stimuli / "data")], capsys, box, "inside the stimulus set")  # fmt: skip
    refused(["run", "luidolt2020", "--participant", "P1", "--out", str(box / "data"),
             "--screenshot", str(stimuli / "a.png")], capsys, box, "inside the stimulus set")  # fmt: skip


def test_a_new_calibration_never_replaces_a_verified_one(box, capsys):
    calibration = fit_calibration(read_readings(READINGS), bit_depth=10)
    measured = [(t, int(np.argmin(abs(calibration.lut - t))), t) for t in (5.0, 50.0, 200.0)]
    verified = box / "display.json"
    calibration.verified(measured).save(verified)
    original = verified.read_bytes()
    fit = ["calibrate", "fit", str(READINGS), "--out", str(verified)]
    assert main(fit) == 0
    assert verified.read_bytes() == original
    assert Calibration.load(box / "display-2.json").status == "unverified"
    assert main(fit) == 0 and (box / "display-3.json").is_file()
    assert main([*fit, "--replace"]) == 0
    assert Calibration.load(verified).status == "unverified"
    assert (box / "display.replaced-2.json").read_bytes() == original
    # a verified calibration as the output of another command is refused
    refused(["render", str(box / "in.exr"), str(box / "o.exr"), "--pixel-deg", "0.02",
             "--preview", str(box / "display.replaced-2.json")], capsys, box,
            "preview must be named .png")  # fmt: skip


def test_measure_after_fit_keeps_fits_calibration_and_takes_the_next_name(box, monkeypatch):
    # docs/workflow.md step 2: `calibrate fit` then `calibrate measure` on the same --out; the
    # measurement goes to the next free name (it once refused the file fit had just written)
    import glarelab.commands.calibrate as calibrate

    out = box / "my-display.json"
    assert main(["calibrate", "fit", str(READINGS), "--out", str(out), "--bit-depth", "10"]) == 0
    written = out.read_bytes()
    measured = []
    monkeypatch.setattr(calibrate, "_measure_locked", lambda args: measured.append(args.out) or 0)
    assert main(["calibrate", "measure", "--out", str(out), "--bit-depth", "10"]) == 0
    assert measured == [box / "my-display-2.json"] and out.read_bytes() == written
    # a second fit keeps both and goes on counting
    assert main(["calibrate", "fit", str(READINGS), "--out", str(out), "--bit-depth", "10"]) == 0
    assert out.read_bytes() == written and (box / "my-display-2.json").is_file()


def _edited(box: Path, change, method: str = "gog") -> Path:
    calibration = fit_calibration(read_readings(READINGS), bit_depth=10, method=method)
    data = calibration.to_json()
    change(data)
    path = box / "edited.json"
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize(
    ("change", "culprit"),
    [
        (lambda d: d["model"].update(gamma=1.0), "gamma is 1.0, its readings give"),
        (lambda d: d["model"].update(gamma=float("nan")), "gamma is nan"),
        (lambda d: d["model"].update(gamma="2.2"), "with model gamma '2.2': a gain-offset-gamma"),
        (lambda d: d["model"].pop("gain"), "with model gain None: a gain-offset-gamma"),
        (lambda d: d.update(max_cd_m2=5000.0), "max_cd_m2 is 5000.0"),
        (lambda d: d.update(status="passed"), "without verification measurements"),
        (lambda d: d.update(status="great"), "status 'great' is not one of"),
    ],
)
def test_an_edited_calibration_is_refused(box, capsys, change, culprit):
    path = _edited(box, change)
    refused(["render", str(box / "in.exr"), str(box / "o.exr"), "--pixel-deg", "0.02",
             "--calibration", str(path)], capsys, box, culprit)  # fmt: skip


def test_the_synthetic_calibration_relabelled_passed_is_refused(box, capsys):
    data = json.loads(
        (ROOT / "calibrations" / "SYNTHETIC-yoshida2008-433cd-10bit.json").read_text()
    )
    data["status"] = "passed"
    (box / "relabelled.json").write_text(json.dumps(data))
    refused(["render", str(box / "in.exr"), str(box / "o.exr"), "--pixel-deg", "0.02",
             "--calibration", str(box / "relabelled.json")], capsys, box,
            "without verification measurements")  # fmt: skip


def _protocol(box: Path, name: str, old: str, new: str, source: str) -> Path:
    text = (ROOT / "src" / "glarelab" / "protocols" / f"{source}.toml").read_text()
    assert old in text, old
    path = box / f"{name}.toml"
    path.write_text(text.replace(old, new, 1))
    return path


QUESTION = '\n[[questionnaire.questions]]\ntext = "Did it glow?"\ncolumn = "trial"\n'


@pytest.mark.parametrize(
    ("source", "old", "new", "culprit"),
    [
        ("yoshida2008", "[analysis]", QUESTION + "\n[analysis]", "column = 'trial'"),
        ("night2026", "frame_rate_hz = 10.0", "frame_rate_hz = 240.0", "frame_rate_hz = 240"),
        ("night2026", "frame_rate_hz = 10.0", "frame_rate_hz = 7.0", "whole number of"),
        ("night2026", "seconds = 3.0", "seconds = 60.0", "pixel-frames"),
        (
            "spencer1995",
            "presentation_ms = [400.0, 700.0]",
            "presentation_ms = [10.0, 700.0]",
            "shorter than one frame",
        ),
        (
            "spencer1995",
            "timing_tolerance_ms = 10.0",
            "timing_tolerance_ms = 1.0",
            "not a whole number of 13.16 ms frames",
        ),
        ("spencer1995", 'paradigm = "staircase"', 'paradigm = ["staircase"]', "study.paradigm"),
        ("yoshida2008", "sigma_deg = 0.34", "sigma_deg = 1e300", "sigma_deg must be at most"),
    ],
)
def test_protocol_check_refuses_what_the_display_or_the_csv_cannot_hold(
    box, capsys, source, old, new, culprit
):
    path = _protocol(box, "bad", old, new, source)
    refused(["protocol", "check", str(path)], capsys, box, culprit)


def test_a_deeply_nested_protocol_is_refused(box, capsys):
    (box / "deep.toml").write_text(
        '[study]\nname = "x"\nparadigm = "matching"\n[glare]\nmethods = '
        + "[" * 3000
        + "]" * 3000
        + "\n"
    )
    refused(["protocol", "check", str(box / "deep.toml")], capsys, box, "nested too deeply")


def _png_header_only(path: Path, width: int, height: int) -> None:
    """A PNG that claims ``width × height`` pixels and holds almost no data (a bomb)."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(b"\0" * 64))
        + chunk(b"IEND", b"")
    )  # fmt: skip


def test_a_huge_aperture_image_is_refused_before_decoding(box, capsys):
    _png_header_only(box / "huge.png", 20000, 20000)
    refused(["psf", "--out", str(box / "k.png"), "--aperture-image", str(box / "huge.png"),
             "--size", "11", "--pixel-deg", "0.05", "--aperture-spacing-mm", "0.1"], capsys, box,
            "may have at most")  # fmt: skip


def test_a_truncated_exr_is_refused_by_name_wherever_it_is_cut(box, capsys):
    data = (box / "in.exr").read_bytes()
    for size in (5, 100, 312, 330, len(data) // 2, len(data) - 1):
        (box / "cut.exr").write_bytes(data[:size])
        refused(["render", str(box / "cut.exr"), str(box / "o.exr"), "--pixel-deg", "0.02"],
                capsys, box, "cut.exr")  # fmt: skip


@pytest.mark.parametrize("participant", ["P01\n", "P 01", "P.01", "P01/x"])
def test_a_participant_id_with_a_line_break_or_dot_is_refused(box, capsys, participant):
    refused(["run", "luidolt2020", "--simulate", "--participant", participant, "--out",
             str(box / "data")], capsys, box, "--participant")  # fmt: skip


def test_analysis_refuses_ids_with_line_breaks_repeated_columns_and_digit_groups(
    box, capsys, tmp_path_factory
):
    data = tmp_path_factory.mktemp("data")
    assert (
        main(["run", "luidolt2020", "--simulate", "--participants", "2", "--out", str(data)]) == 0
    )
    capsys.readouterr()
    first = sorted(data.glob("*.csv"))[0]
    lines = first.read_text().splitlines()
    header = lines[0].split(",")
    cells = lines[1].split(",")
    column = header.index("participant")
    for name, edit, culprit in [
        ("newline", lambda c: c.__setitem__(column, '"P1\n"'), "is not a participant id"),
        (
            "group",
            lambda c: c.__setitem__(header.index("trial"), "2_50"),
            "'2_50' is not a whole number",
        ),
    ]:
        changed = list(cells)
        edit(changed)
        path = box / f"{name}.csv"
        path.write_text("\n".join([lines[0], ",".join(changed), *lines[2:]]) + "\n")
        shutil.copy(first.with_suffix(".json"), path.with_suffix(".json"))
        refused(["analyse", "luidolt2020", str(path), "--out", str(box / "report")], capsys,
                box, culprit)  # fmt: skip
    twice = box / "twice.csv"
    twice.write_text(
        "\n".join([lines[0] + ",trial", *(line + "," + line.split(",")[3] for line in lines[1:])])
        + "\n"
    )
    shutil.copy(first.with_suffix(".json"), twice.with_suffix(".json"))
    refused(["analyse", "luidolt2020", str(twice), "--out", str(box / "report")], capsys, box,
            "appear more than once")  # fmt: skip


def test_a_command_that_needs_a_screen_is_refused_without_one(box, capsys, monkeypatch):
    monkeypatch.setenv("DISPLAY", ":9876")  # no X server there
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    refused(["check-display", "spencer1995", "--out", str(box / "d.json")], capsys, box,
            "no display to open a window on")  # fmt: skip
    refused(["calibrate", "measure", "--out", str(box / "c.json")], capsys, box,
            "no display to open a window on")  # fmt: skip


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT)}


def _terminal_sigint() -> None:
    """Ctrl-C as a terminal delivers it: a test runner started in the background of a shell
    has SIGINT ignored, and its children would inherit that."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_a_closed_pipe_ends_quietly_with_status_0():
    shown = subprocess.run(
        f"{' '.join(PYTHON)} protocol keys yoshida2008 | head -1; exit ${{PIPESTATUS[0]}}",
        shell=True, executable="/bin/bash", capture_output=True, text=True, env=_env(),
        timeout=120,
    )  # fmt: skip
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.count("\n") == 1
    assert "Traceback" not in shown.stderr and "BrokenPipe" not in shown.stderr


def test_ctrl_c_ends_a_stimulus_build_quietly_with_status_3(tmp_path):
    import threading

    process = subprocess.Popen(
        [*PYTHON, "stimuli", "build", "spencer1995", "--out", str(tmp_path / "set")],
        env={**_env(), "GLARELAB_NO_CACHE": "1"}, stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL, preexec_fn=_terminal_sigint,
    )  # fmt: skip
    chunks: list[bytes] = []
    started = threading.Event()

    def read() -> None:
        while chunk := process.stderr.read1(4096):
            chunks.append(chunk)
            started.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    assert started.wait(120), "the build printed no progress"
    time.sleep(0.3)  # building its images (its progress bar reaches the pipe only at the end)
    process.send_signal(signal.SIGINT)
    process.wait(timeout=120)
    reader.join(timeout=10)
    err = b"".join(chunks).decode(errors="replace")
    assert process.returncode == 3, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    assert "stopped by SIGINT" in err
    assert not (tmp_path / "set").exists()
    assert not list(tmp_path.glob(".set.*"))


def test_ctrl_c_to_the_terminal_ends_a_power_run_without_worker_tracebacks(tmp_path):
    """Ctrl-C reaches the whole process group, the Dask workers too: one line, status 3."""
    import threading

    process = subprocess.Popen(
        [*PYTHON, "power", "luidolt2020", "--participants", "4", "--replications", "500",
         "--workers", "1", "--out", str(tmp_path / "power")],
        env=_env(), stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, start_new_session=True,
        preexec_fn=_terminal_sigint,
    )  # fmt: skip
    chunks: list[bytes] = []
    running = threading.Event()

    def read() -> None:
        while chunk := process.stderr.read1(4096):
            chunks.append(chunk)
            if b"1/500 replications" in b"".join(chunks):
                running.set()

    threading.Thread(target=read, daemon=True).start()
    assert running.wait(240), b"".join(chunks).decode(errors="replace")[-2000:]
    os.killpg(process.pid, signal.SIGINT)
    process.wait(timeout=120)
    time.sleep(0.5)
    err = b"".join(chunks).decode(errors="replace")
    assert process.returncode == 3, err[-2000:]
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err[-2000:]


def test_a_sky_contrast_the_ceiling_cuts_is_refused_not_stated(box, capsys):
    path = _protocol(box, "contrast", "contrast = 0.15 ", "contrast = 1.0 ", "yoshida2008")
    refused(["stimuli", "build", str(path), "--out", str(box / "set")], capsys, box,
            "background.contrast = 1: the sky reaches only 0.4")  # fmt: skip


def test_an_edited_power_log_or_run_file_is_refused_on_resume(tmp_path, capsys):
    out = tmp_path / "power"
    power = ["power", "luidolt2020", "--participants", "4", "--workers", "0", "--out", str(out)]
    assert main([*power, "--replications", "2"]) == 0
    log = out / "replications.jsonl"
    lines = log.read_text().splitlines()
    record = json.loads(lines[0])
    assert "sha256" in record and "run" in record
    original = log.read_text()
    edited = original.replace(lines[0], lines[0].replace('"task": 0', '"task": 7'), 1)
    assert edited != original
    log.write_text(edited)
    refused([*power, "--replications", "3"], capsys, tmp_path, "line 1: edited")
    log.write_text(original)
    run = json.loads((out / "run.json").read_text())
    run["seed"] = 5
    (out / "run.json").write_text(json.dumps(run, indent=2, sort_keys=True) + "\n")
    refused([*power, "--replications", "3", "--seed", "5"], capsys, tmp_path,
            "made with other inputs")  # fmt: skip


def test_the_time_left_leaves_out_the_workers_start_up(monkeypatch):
    """100 s of start-up, then a task a second: 97 tasks left are 1m37s, not an hour."""
    import io

    import glarelab.planning.execute as execute

    now = [0.0]
    clock = type("Clock", (), {"perf_counter": staticmethod(lambda: now[0])})
    monkeypatch.setattr(execute, "time", clock)  # this module's clock only
    bar = execute.Progress(100, what="replications", stream=io.StringIO())
    for t in (100.0, 101.0, 102.0):
        now[0] = t
        bar.update()
    assert bar.line().endswith("1/s, 1m37s left"), bar.line()
