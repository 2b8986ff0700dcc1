"""Faults while writing: a command killed (SIGKILL) at a random moment, or one that meets a full
disk, leaves its earlier complete output or a complete new one, never a mix or a partial file.

Each command runs in a forked copy of this process (so that no kill waits for the imports), is
killed after a random delay drawn over its measured run time, and the output is then compared
by hash with the complete earlier and the complete new output. The computation before the
first file is written (the images of a set, the statistics of a report) is done once in this
process and reused by the forked copies, so that the kills fall where files are written.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import pickle
import select
import shutil
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from glarelab.cli import main
from glarelab.files.atomic import PARTIAL
from glarelab.stimuli.exr import write_exr

ROOT = Path(__file__).parents[1]
KILLS = 30


def tiny_matching_protocol() -> str:
    """yoshida2008 with one method, two levels and a small image (builds in a second)."""
    text = (ROOT / "src" / "glarelab" / "protocols" / "yoshida2008.toml").read_text()
    text = text.replace("distance_m = 1.0", "distance_m = 0.25")
    text = text.replace("size_deg = 3.2 ", "size_deg = 1.2 ")
    text = text.replace("cloud_max_deg = 3.2", "cloud_max_deg = 1.2")
    text = text.replace("supersample = 2 ", "supersample = 1 ")
    # 6.9 display pixels across: a disk whose drawn pixels hold its light to 0.2 %
    text = text.replace("disk_deg = 0.3 ", "disk_deg = 0.325 ")
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


def fork_main(argv: list[str]) -> int:
    """Start ``glarelab argv`` in a forked child of its own process group, its output
    discarded (exit status 99 for an exception); the child's pid."""
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
    return pid


def run_forked(argv: list[str], kill_after_s: float | None) -> int | None:
    """Run ``glarelab argv`` in a forked child; SIGKILL it after ``kill_after_s`` (None: let
    it finish). The child's exit status, or None when it was killed."""
    pid = fork_main(argv)
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
    listing = tmp_path / ".glarelab-files.json"  # what the folder records of it, its content
    recorded = listing.read_bytes()
    before = digest(out)
    argv = [*base, "--model", "gaussian", "--sigma-deg", "0.5"]
    assert main(argv) == 0
    after = digest(out)
    assert after != before

    def reset():  # the folder as the first render left it (else out.exr is 'edited since')
        shutil.copy(earlier, out)
        listing.write_bytes(recorded)

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
    import dataclasses

    from glarelab.stimuli import paradigms

    for paradigm, entry in list(paradigms.PARADIGMS.items()):
        memo = type("Memo", (), {})()
        memo.build = entry.build
        memoised(memo, "build", monkeypatch)
        monkeypatch.setitem(
            paradigms.PARADIGMS, paradigm, dataclasses.replace(entry, build=memo.build)
        )
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


SUMMARIES = (
    "power.csv",
    "effect_sizes.csv",
    "recommended.csv",
    "power_curves.png",
    "effect_sizes.png",
)


def summaries(folder: Path) -> tuple[str, ...]:
    """The digests of a power run's five summaries, together."""
    return tuple(digest(folder / name) for name in SUMMARIES)


@pytest.fixture
def quick_power(monkeypatch):
    """``glarelab power`` with its replications and figures computed once per argument, and
    a pipe on which each run writes ``s`` as it starts writing its first summary file and
    ``e`` when all are in place (the read end, non-blocking)."""
    import glarelab.planning.power as power
    from glarelab.planning.simulate import PowerJob

    run, results = PowerJob.run, {}

    def once(job, replication):
        key = (job.protocol.sha256, job.seed, job.participants, replication)
        if key not in results:
            results[key] = run(job, replication)
        return results[key]

    monkeypatch.setattr(PowerJob, "run", once)
    memoised(power, "power_figure", monkeypatch)
    memoised(power, "effect_size_figure", monkeypatch)
    read, write = os.pipe()
    os.set_blocking(read, False)
    write_summary, write_bytes, writing = power.write_summary, power.write_bytes, []

    def marked(*args, **kwargs):
        writing.clear()
        try:
            return write_summary(*args, **kwargs)
        finally:
            os.write(write, b"e")

    def first_marked(path, data):
        if not writing:
            writing.append(path)
            os.write(write, b"s")
        return write_bytes(path, data)

    monkeypatch.setattr(power, "write_summary", marked)
    monkeypatch.setattr(power, "write_bytes", first_marked)
    yield read
    os.close(read)
    os.close(write)


def drain(pipe: int) -> None:
    with contextlib.suppress(BlockingIOError):
        while os.read(pipe, 100):
            pass


def next_mark(pipe: int, timeout_s: float = 60.0) -> tuple[bytes, float]:
    """The next byte on ``pipe`` and when it came (time.monotonic)."""
    if not select.select([pipe], [], [], timeout_s)[0]:
        raise TimeoutError("no mark on the pipe")
    return os.read(pipe, 1), time.monotonic()


def kill_in_summary(argv: list[str], pipe: int, delay_s: float) -> float | None:
    """Run ``glarelab argv`` forked and SIGKILL it ``delay_s`` after it starts writing its
    summaries (``quick_power``'s marks). How long they took if they were all written before
    the kill; None if it came while they were being written."""
    drain(pipe)
    pid = fork_main(argv)
    took = None
    try:
        mark, began = next_mark(pipe)
        assert mark == b"s"
        if select.select([pipe], [], [], delay_s)[0]:
            mark, ended = next_mark(pipe)
            assert mark == b"e"
            took = ended - began
            time.sleep(max(0.0, began + delay_s - time.monotonic()))
    finally:
        os.kill(pid, signal.SIGKILL)  # a child that has ended is a zombie until waited for
    os.waitpid(pid, 0)
    return took


def test_a_killed_power_run_leaves_the_earlier_summaries_or_the_new_ones_and_resumes(
    tmp_path, quick_power, capsys
):
    out = tmp_path / "power"
    common = ["power", "luidolt2020", "--participants", "4", "6", "--workers", "0"]
    common += ["--out", str(out)]
    assert main([*common, "--replications", "4"]) == 0
    (out / "notes.txt").write_text("the lab's own notes\n")  # a user's file, kept throughout
    earlier = tmp_path / "earlier"
    shutil.copytree(out, earlier)
    reference = tmp_path / "reference"
    more = ["--replications", "8", "--target-power", "0.9"]  # every summary differs
    argv = [*common, *more]
    assert main([*common[:-1], str(reference), *more]) == 0
    before, after = summaries(earlier), summaries(reference)
    assert all(old != new for old, new in zip(before, after, strict=True))  # any mix is seen

    def reset():
        shutil.rmtree(out)
        shutil.copytree(earlier, out)

    def check(seen: dict[str, int]) -> None:
        now = summaries(out)
        state = "before" if now == before else "after" if now == after else "mixed"
        seen[state] += 1
        assert state != "mixed", f"a kill left a mix of summaries: {now}"
        assert (out / "notes.txt").read_text() == "the lab's own notes\n"
        visible = [p for p in out.rglob("*") if PARTIAL in p.name and not p.name.startswith(".")]
        assert not visible, visible

    # the run's time, and the time it takes to write the summaries (median of three)
    runs, writes = [], []
    for _ in range(3):
        reset()
        drain(quick_power)
        start = time.monotonic()
        assert run_forked(argv, None) == 0
        runs.append(time.monotonic() - start)
    for _ in range(3):
        reset()
        drain(quick_power)
        pid = fork_main(argv)
        (first, began), (second, ended) = next_mark(quick_power), next_mark(quick_power)
        assert (first, second) == (b"s", b"e")
        assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 0
        writes.append(ended - began)
    seconds, writing = float(np.median(runs)), float(np.median(writes))
    rng = np.random.default_rng(4)
    anywhere = {"before": 0, "after": 0, "mixed": 0}
    tries = killed = 0  # the kills that came after the run had ended do not count
    while killed < KILLS:  # at random over the whole run
        tries += 1
        assert tries <= 4 * KILLS, f"only {killed} of {tries} kills came while the run ran"
        reset()
        killed += run_forked(argv, float(rng.uniform(0.0, 1.1 * seconds))) is None
        check(anywhere)
    writing_kills = {"before": 0, "after": 0, "mixed": 0}
    inside = timed = 0  # kills that came while the summaries were being written, and all
    window = writing  # follows the pace of a shared machine's disk: the delays scale with it
    # at random from the start of the summaries, until KILLS of them and three on each side
    # of the swap (a loaded machine writes slower than it did when the window was measured)
    while timed < KILLS or min(writing_kills["before"], writing_kills["after"]) < 3:
        timed += 1
        assert timed <= 4 * KILLS, f"{timed} kills from the summaries left {writing_kills}"
        reset()
        delay = float(rng.uniform(0.0, 1.5 * window))
        took = kill_in_summary(argv, quick_power, delay)
        inside += took is None
        window = 1.25 * max(window, delay) if took is None else took
        writes += [] if took is None else [took]
        check(writing_kills)
    with capsys.disabled():
        print(
            f"\npower run {1e3 * seconds:.0f} ms, its summaries written in "
            f"{1e3 * float(np.median(writes)):.1f} ms (median); {tries} kills at random "
            f"({killed} while it ran) left {anywhere}; {timed} kills from the start of the "
            f"summaries ({inside} while they were written) left {writing_kills}"
        )
    # the kills fell while the summaries were written, on both sides of the swap
    assert inside >= KILLS // 4, inside
    assert writing_kills["before"] >= 3 and writing_kills["after"] >= 3, writing_kills
    assert main(argv) == 0  # a run after the kills resumes to the uninterrupted result
    assert summaries(out) == after
    assert (out / "notes.txt").read_text() == "the lab's own notes\n"
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []


def test_a_power_run_killed_between_two_renames_is_put_back_by_the_next_run(
    tmp_path, quick_power, monkeypatch
):
    """Where the file system cannot swap two folders in one step, the earlier folder is moved
    aside before the new one is moved in: a run killed between the two renames leaves no
    folder, and the next run puts the earlier one back before it reads it."""
    import glarelab.files.folders as folders

    out = tmp_path / "power"
    common = ["power", "luidolt2020", "--participants", "4", "--workers", "0"]
    assert main([*common, "--replications", "2", "--out", str(out)]) == 0
    (out / "notes.txt").write_text("the lab's own notes\n")
    before, log = summaries(out), (out / "replications.jsonl").read_bytes()
    argv = [*common, "--replications", "4", "--out", str(out)]
    assert main([*common, "--replications", "4", "--out", str(tmp_path / "whole")]) == 0
    with monkeypatch.context() as patch:
        patch.setattr(folders, "_exchange", lambda first, second: False)
        rename = Path.rename

        def rename_then_die(self, target):
            moved = rename(self, target)
            if ".old-" in Path(target).name:  # the earlier folder is aside, the new not in
                os.kill(os.getpid(), signal.SIGKILL)
            return moved

        patch.setattr(Path, "rename", rename_then_die)
        assert run_forked(argv, None) is None  # killed
    assert not out.exists()
    (aside,) = tmp_path.glob(".power.old-*")
    assert summaries(aside) == before
    assert main(argv) == 0
    assert (out / "notes.txt").read_text() == "the lab's own notes\n"
    lines = (out / "replications.jsonl").read_bytes()
    assert lines.startswith(log) and len(lines.splitlines()) == 4  # resumed: none lost
    assert summaries(out) == summaries(tmp_path / "whole")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["power", "whole"]


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


def fill(disk: Path) -> None:
    """Take the rest of ``disk``'s space."""
    handle = os.open(disk / "filler", os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    try:
        while True:
            os.write(handle, b"\0" * 65536)
    except OSError:
        pass
    finally:
        os.close(handle)


def test_a_power_run_on_a_full_disk_leaves_the_earlier_summaries_and_no_partial_file(
    small_disk, quick_power, monkeypatch, capsys
):
    import glarelab.planning.power as power

    out = small_disk / "power"
    common = ["power", "luidolt2020", "--participants", "4", "--workers", "0"]
    assert main([*common, "--replications", "2", "--out", str(out)]) == 0
    before = summaries(out)
    write_summary = power.write_summary

    def on_a_full_disk(*args, **kwargs):  # the replications are in; the disk fills up
        fill(small_disk)
        return write_summary(*args, **kwargs)

    monkeypatch.setattr(power, "write_summary", on_a_full_disk)
    capsys.readouterr()
    argv = [*common, "--replications", "3", "--target-power", "0.9", "--out", str(out)]
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2 and "disk is full" in err and "Traceback" not in err, err
    assert len([line for line in err.splitlines() if line.startswith("glarelab ")]) == 1
    assert summaries(out) == before
    assert sorted(p.name for p in small_disk.iterdir()) == ["filler", "power"]
    assert not [p for p in small_disk.rglob("*") if PARTIAL in p.name]
    # with room again, the run completes from the replications it kept
    (small_disk / "filler").unlink()
    monkeypatch.setattr(power, "write_summary", write_summary)
    assert main(argv) == 0
    assert summaries(out) != before and all(s != "missing" for s in summaries(out))


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
