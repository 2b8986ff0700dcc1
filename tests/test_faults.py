"""Faults while writing: a command killed (SIGKILL) at a random moment, or one that meets a full
disk, leaves its earlier complete output or a complete new one, never a mix or a partial file.

Each command runs in a forked copy of this process (so that no kill waits for the imports), is
killed after a random delay drawn over its measured run time, and the output is then compared
by hash with the complete earlier and the complete new output. The computation before the
first file is written (the images of a set, the statistics of a report) is done once in this
process and reused by the forked copies, so that the kills fall where files are written.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest
from glarelab.protocols.atomic import PARTIAL
from glarelab.stimuli.exr import write_exr

from glarelab.cli import main

ROOT = Path(__file__).parents[1]
KILLS = 30


def tiny_matching_protocol() -> str:
    """yoshida2008 with one method, two levels and a small image (builds in a second)."""
    text = (ROOT / "protocols" / "yoshida2008.toml").read_text()
    text = text.replace("distance_m = 1.0", "distance_m = 0.25")
    text = text.replace("size_deg = 3.2 ", "size_deg = 1.2 ")
    text = text.replace("cloud_max_deg = 3.2", "cloud_max_deg = 1.2")
    text = text.replace("supersample = 2 ", "supersample = 1 ")
    text = text[: text.index("[[glare.methods]]     # Method II")] + text[text.index("[trials]") :]
    text = text.replace(
        'labels = ["A", "B", "C", "D", "E", "F"]\n'
        "levels_cd_m2 = [220.0, 1165.0, 2110.0, 3055.0, 4000.0, 7000.0]",
        'labels = ["A", "B"]\nlevels_cd_m2 = [220.0, 4000.0]',
    )
    return text[: text.index("[analysis]")] + "[analysis]\ncompare_methods_at = []\n"


def digest(path: Path) -> str:
    """sha256 of a file, or of a folder's every visible file (names and contents)."""
    path = Path(path)
    if path.is_file():
        return hashlib.sha256(path.read_bytes()).hexdigest()
    if not path.exists():
        return "missing"
    total = hashlib.sha256()
    for item in sorted(p for p in path.rglob("*") if p.is_file()):
        name = item.relative_to(path).as_posix()
        if name.startswith(".glarelab-files") or name == ".glarelab":
            continue
        total.update(name.encode() + b"\0" + hashlib.sha256(item.read_bytes()).digest())
    return total.hexdigest()


def run_forked(argv: list[str], kill_after_s: float | None) -> int | None:
    """Run ``glarelab argv`` in a forked child; SIGKILL it after ``kill_after_s`` (None: let
    it finish). The child's exit status, or None when it was killed."""
    pid = os.fork()
    if pid == 0:  # the child
        os.setpgid(0, 0)
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        try:
            status = main(argv)
        except BaseException:
            status = 99
        os._exit(status)
    if kill_after_s is not None:
        deadline = time.monotonic() + kill_after_s
        while time.monotonic() < deadline:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                return os.waitstatus_to_exitcode(status)
            time.sleep(0.002)
        os.kill(pid, signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    code = os.waitstatus_to_exitcode(status)
    return None if code == -signal.SIGKILL else code


def kill_at_random(argv, output: Path, before: str, after: str, seed: int) -> dict[str, int]:
    """Kill ``argv`` KILLS times at random moments over its run time; after each kill the
    output must be ``before`` or ``after`` (and is reset to ``before``). How many kills left
    which."""
    start = time.monotonic()
    assert run_forked(argv, None) == 0
    seconds = time.monotonic() - start
    assert digest(output) == after
    rng = np.random.default_rng(seed)
    seen = {"before": 0, "after": 0}
    for _ in range(KILLS):
        reset = yield  # the caller puts the earlier output back
        del reset
        run_forked(argv, float(rng.uniform(0.0, 1.1 * seconds)))
        now = digest(output)
        assert now in (before, after), f"a kill left a mix of outputs in {output}"
        seen["before" if now == before else "after"] += 1
        visible = [
            p for p in output.parent.rglob("*") if PARTIAL in p.name and not p.name.startswith(".")
        ]
        assert not visible, visible
    return seen


def drive(generator, reset) -> dict[str, int]:
    next(generator)
    try:
        while True:
            reset()
            generator.send(None)
    except StopIteration as stop:
        return stop.value


def test_a_killed_render_leaves_the_earlier_image_or_the_new_one(tmp_path):
    image = np.full((96, 96), 1.0, np.float32)
    image[44:52, 44:52] = 5e4
    write_exr(tmp_path / "scene.exr", image)
    out = tmp_path / "out.exr"
    base = ["render", str(tmp_path / "scene.exr"), str(out), "--pixel-deg", "0.02"]
    assert main([*base, "--model", "gaussian", "--sigma-deg", "0.2"]) == 0
    earlier = tmp_path / "earlier.exr"
    shutil.copy(out, earlier)
    before = digest(out)
    argv = [*base, "--model", "gaussian", "--sigma-deg", "0.5"]
    assert main(argv) == 0
    after = digest(out)
    assert after != before

    def reset():
        shutil.copy(earlier, out)

    reset()
    seen = drive(kill_at_random(argv, out, before, after, seed=1), reset)
    assert sum(seen.values()) == KILLS


def memoised(module, name: str, monkeypatch) -> None:
    """``module.name`` computed once per argument (the forked copies inherit the results)."""
    original = getattr(module, name)
    results = {}

    def once(*args, **kwargs):
        try:
            key = pickle.dumps((args, sorted(kwargs.items())))
        except (pickle.PicklingError, TypeError, AttributeError):
            key = repr((args, sorted(kwargs.items())))
        if key not in results:
            results[key] = original(*args, **kwargs)
        return results[key]

    monkeypatch.setattr(module, name, once)


def test_a_killed_stimulus_build_leaves_the_earlier_set_or_the_new_one(tmp_path, monkeypatch):
    import glarelab.stimuli.stimulus_set as stimulus_set

    builders = dict(stimulus_set.BUILDERS)
    for paradigm in builders:
        memo = type("Memo", (), {})()
        memo.build = builders[paradigm]
        memoised(memo, "build", monkeypatch)
        builders[paradigm] = memo.build
    monkeypatch.setattr(stimulus_set, "BUILDERS", builders)
    old, new = tmp_path / "old.toml", tmp_path / "new.toml"
    text = tiny_matching_protocol()
    old.write_text(text)
    new.write_text(text.replace("seed = 2008", "seed = 7"))
    out = tmp_path / "set"
    assert main(["stimuli", "build", str(old), "--out", str(out)]) == 0
    before = digest(out)
    earlier = tmp_path / "earlier"
    shutil.copytree(out, earlier, symlinks=True)
    argv = ["stimuli", "build", str(new), "--out", str(out)]

    def reset():
        shutil.rmtree(out, ignore_errors=True)
        shutil.copytree(earlier, out, symlinks=True)

    assert main(argv) == 0
    after = digest(out)
    assert after != before
    reset()
    seen = drive(kill_at_random(argv, out, before, after, seed=2), reset)
    assert sum(seen.values()) == KILLS
    assert main(["stimuli", "verify", str(out)]) == 0
    # a later build clears what killed builds left beside the set
    assert main(argv) == 0
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".set")) == []


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sessions")
    assert (
        main(["run", "luidolt2020", "--simulate", "--participants", "3", "--out", str(folder)])
        == 0
    )
    return sorted(folder.glob("*.csv"))


def test_a_killed_analysis_leaves_the_earlier_report_or_the_new_one(
    tmp_path, sessions, monkeypatch
):
    import glarelab.analysis.report as report

    memoised(report, "analyse", monkeypatch)
    out = tmp_path / "report"
    assert main(["analyse", "luidolt2020", *map(str, sessions[:2]), "--out", str(out)]) == 0
    before = digest(out)
    earlier = tmp_path / "earlier"
    shutil.copytree(out, earlier)
    argv = ["analyse", "luidolt2020", *map(str, sessions), "--out", str(out)]

    def reset():
        shutil.rmtree(out, ignore_errors=True)
        shutil.copytree(earlier, out)

    assert main(argv) == 0
    after = digest(out)
    assert after != before
    reset()
    seen = drive(kill_at_random(argv, out, before, after, seed=3), reset)
    assert sum(seen.values()) == KILLS


def test_a_killed_power_run_leaves_each_file_complete_and_resumes(tmp_path, monkeypatch):
    from glarelab.planning.simulate import PowerJob

    run, results = PowerJob.run, {}

    def once(job, replication):
        key = (job.protocol.sha256, job.seed, job.participants, replication)
        if key not in results:
            results[key] = run(job, replication)
        return results[key]

    monkeypatch.setattr(PowerJob, "run", once)
    import glarelab.planning.power as power

    memoised(power, "power_figure", monkeypatch)
    memoised(power, "effect_size_figure", monkeypatch)
    out = tmp_path / "power"
    common = ["power", "luidolt2020", "--participants", "4", "6", "--workers", "0"]
    common += ["--out", str(out)]
    assert main([*common, "--replications", "4"]) == 0
    summary = ["power.csv", "effect_sizes.csv", "recommended.csv", "power_curves.png"]
    earlier = tmp_path / "earlier"
    shutil.copytree(out, earlier)
    reference = tmp_path / "reference"
    argv = [*common, "--replications", "8"]
    assert argv[-4:-2] == ["--out", str(out)]
    assert main([*argv[:-3], str(reference), "--replications", "8"]) == 0
    after = {name: digest(reference / name) for name in summary}
    before = {name: digest(earlier / name) for name in summary}
    rng = np.random.default_rng(4)
    start = time.monotonic()
    assert run_forked(argv, None) == 0
    seconds = time.monotonic() - start
    for _ in range(KILLS):
        shutil.rmtree(out)
        shutil.copytree(earlier, out)
        run_forked(argv, float(rng.uniform(0.0, 1.1 * seconds)))
        for name in summary:  # each summary file is the earlier one or the new one, whole
            assert digest(out / name) in (before[name], after[name]), name
    assert main(argv) == 0  # a run after the kills resumes to the uninterrupted result
    assert {name: digest(out / name) for name in summary} == after


@pytest.fixture
def small_disk(tmp_path):
    """A 1 MiB tmpfs (root only); skipped where mounting is not permitted."""
    folder = tmp_path / "disk"
    folder.mkdir()
    try:
        subprocess.run(
            ["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(folder)],
            check=True,
            capture_output=True,
            timeout=20,
        )
    except (OSError, subprocess.SubprocessError):
        pytest.skip("cannot mount a small tmpfs here (needs root)")
    yield folder
    subprocess.run(["umount", "-l", str(folder)], check=False, capture_output=True)


def test_a_full_disk_leaves_the_earlier_file_and_no_partial_one(small_disk, tmp_path, capsys):
    small = np.full((32, 32), 1.0, np.float32)
    write_exr(tmp_path / "small.exr", small)
    out = small_disk / "out.exr"
    argv = ["render", str(tmp_path / "small.exr"), str(out), "--pixel-deg", "0.02"]
    assert main([*argv, "--model", "gaussian"]) == 0
    before = digest(out)
    noise = np.random.default_rng(0).uniform(1, 2, (700, 700)).astype(np.float32)  # ~2 MB
    write_exr(tmp_path / "large.exr", noise)
    capsys.readouterr()
    status = main(["render", str(tmp_path / "large.exr"), str(out), "--pixel-deg", "0.02",
                   "--model", "gaussian"])  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2 and "disk is full" in err and "Traceback" not in err
    assert len([line for line in err.splitlines() if line.startswith("glarelab ")]) == 1
    assert digest(out) == before
    assert sorted(p.name for p in small_disk.iterdir()) == [".glarelab-files.json", "out.exr"]
    # a calibration onto the full disk: the earlier one stays, no partial file
    filler = small_disk / "filler"
    with open(filler, "wb") as handle:
        try:
            handle.write(b"\0" * (2 << 20))
        except OSError:
            pass
    status = main(["calibrate", "fit", str(ROOT / "calibrations" / "example-readings.csv"),
                   "--out", str(small_disk / "display.json")])  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err, err
    assert not (small_disk / "display.json").exists()
    assert not [p for p in small_disk.iterdir() if PARTIAL in p.name]
