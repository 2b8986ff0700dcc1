"""The documentation matches the code: generated references are current, every documented
command exists with the options it uses, and every command of README.md and docs/*.md runs as
printed in a fresh copy of the repository's files (a clone's), its placeholders filled by the
shipped examples.

Nothing is skipped silently: a command that needs the lab (a photometer, a participant at the
lab's display) or that is the test suite itself is listed in ``NOT_RUN`` with the reason and
what runs in its stead; every other command runs, in the order its document gives."""

import glob
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from glarelab.cli import _parser
from glarelab.docs import data_reference, protocol_reference

ROOT = Path(__file__).parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
XVFB = ["xvfb-run", "-a", "-s", "-screen 0 1920x1080x24"]

LAB_SESSION = (
    "a participant at the lab's display; the documented dry run (--scripted-keys) runs the same "
    "session in a window, and tests/experiments/ run sessions with real key events"
)
NOT_RUN = {
    "make test": "the test suite itself, of which this test is a part",
    "make demo": "creates .venv, then runs `glarelab demo --protocol yoshida2008 --out "
    "out/demo`, which tests/test_demo.py runs (test_make_demo_runs_the_tested_command)",
    "glarelab calibrate measure --out calibrations/my-display.json --bit-depth 10": "needs a "
    "photometer; tests/stimuli/test_measure.py runs it with a simulated one",
    "glarelab calibrate measure --out calibrations/my-display.json --bit-depth 10 --photometer "
    "LS-100 --port /dev/ttyUSB0 --photometer-serial 40211007": "needs a photometer; "
    "tests/stimuli/test_photometer.py runs it against a simulated LS-100 under Xvfb",
    "glarelab calibrate measure --out calibrations/my-display.json --photometer LS-100 --port "
    "/dev/ttyUSB0 --resume": "needs a photometer, as above (the same test resumes a session)",
    "glarelab check-display yoshida2008 --calibration calibrations/my-display.json --photometer "
    "LS-100 --port /dev/ttyUSB0": "needs a photometer; tests/stimuli/test_photometer.py runs "
    "it against a simulated LS-100 under Xvfb",
    "glarelab bench --out out/bench": "takes minutes; the documented quick run (--only "
    "yoshida2008) runs, and tests/bench/test_run.py checks the rows of the full one",
    "glarelab bench --out out/bench-large --large": "takes a quarter of an hour, as above",
    "glarelab bench --acuity --out docs/bench-acuity": "takes a minute or more; the "
    "documented quick run (--only street_0.0297deg) runs, and tests/bench/test_acuity.py checks its "
    "rows",
    "glarelab bench --live --out out/bench-live": "takes several minutes; "
    "tests/bench/test_live.py runs it on a smaller street and checks the rows",
}
LAB_SESSIONS = [  # README.md and docs/workflow.md: a participant's sessions
    "glarelab run yoshida2008 --participant P01 --stimuli sets/yoshida2008 --calibration "
    "calibrations/my-display.json --fullscreen --age 31 --sex f --vision glasses",
    "glarelab run spencer1995 --participant P02 --stimuli sets/spencer1995 --calibration "
    "calibrations/my-spencer-display.json --fullscreen",
    "glarelab run luidolt2020 --participant P03 --fullscreen",
    "glarelab run yoshida2008 --stimuli sets/yoshida2008 --calibration "
    "calibrations/my-display.json --fullscreen",
    "glarelab run yoshida2008 --participant P01 --stimuli sets/yoshida2008 --calibration "
    "calibrations/my-display.json --fullscreen --resume",
    "glarelab run yoshida2008 --participant P01 --stimuli sets/yoshida2008 --calibration "
    "calibrations/my-display.json --fullscreen --age 29 --sex f --vision none --out data",
    "glarelab run yoshida2008 --participant P01 --stimuli sets/yoshida2008 --calibration "
    "calibrations/my-display.json --fullscreen --resume --out data",
    "glarelab run luidolt2020 --participant P01 --fullscreen --out data",
    "glarelab run night2026 --participant P04 --stimuli sets/night2026 --calibration "
    "calibrations/my-night-display.json --fullscreen",
    "glarelab run night2026 --participant P01 --stimuli sets/night2026 --calibration "
    "calibrations/my-night-display.json --fullscreen",
]
NOT_RUN |= dict.fromkeys(LAB_SESSIONS, LAB_SESSION)
NOT_RUN |= dict.fromkeys(
    [
        "glarelab run luidolt2020-live --pilot --eyetracker mouse --participant P01 --out "
        "data/live",
        "glarelab run luidolt2020-live --eyetracker pupil_core.yaml --participant P01 "
        "--fullscreen --out data/live",
    ],
    "a participant looking around a live scene for a minute (the second with a Pupil Labs "
    "tracker); tests/frontend/test_live_session.py runs the first under Xvfb with real X "
    "events",
)
NOT_RUN |= dict.fromkeys(
    [
        "glarelab power spencer1995 --participants 4 6 8 --replications 1000 --scheduler "
        "tcp://10.0.0.5:8786 --out power/spencer1995",
        "glarelab power spencer1995 --participants 4 6 8 --replications 1000 --scheduler "
        "tcp://10.0.0.5:8786 --out /shared/power/spencer",
        "glarelab power yoshida2008 --participants 6 8 10 --replications 1000 --scheduler "
        "tcp://10.0.0.5:8786 --out /shared/power/yoshida",
        "dask scheduler --port 8786",
        "dask worker tcp://10.0.0.5:8786 --nthreads 1",
    ],
    "needs the lab's Dask cluster; tests/test_power_commands.py starts a scheduler and a "
    "worker and runs the command against them",
)
# a dry run's key script runs out into Escape: the session ends aborted, status 3, as documented
EXIT_STATUS = {"--scripted-keys": 3}
# the display check runs on Xvfb, which is not the protocol's display: these checks fail there
# (exit status 1), and only these; every image of the set must read back exact. The docs ask for
# the check to be run again after a driver change: it runs twice, the second run replacing the
# first's findings.
XVFB_FAILS = {"resolution", "refresh", "refresh-unmeasured", "bit-depth"}
# Xvfb is not the protocol's display, and the example calibration is unverified: say so, as a
# lab running on another display would (docs/workflow.md, step 4)
ON_XVFB = [
    "--accept-mismatch",
    "resolution",
    "refresh",
    "bit-depth",
    "--allow-unmeasured-refresh",
    "--allow-uncalibrated",
]


def commands(document: Path) -> list[str]:
    """Every command of the document's ``sh`` blocks, continued lines joined, comments cut."""
    text = document.read_text()
    found = []
    for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S):
        block = re.sub(r"\\\n\s*", " ", block)
        for line in block.splitlines():
            line = re.sub(r"\s+#.*$", "", line).strip()
            if line:
                found.append(" ".join(line.split()))
    return found


def test_generated_references_are_current():
    assert (ROOT / "docs" / "protocols.md").read_text() == protocol_reference()
    assert (ROOT / "docs" / "data.md").read_text() == data_reference()


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_every_documented_command_parses(document):
    parser = _parser()
    for command in commands(document):
        if not command.startswith("glarelab "):
            continue
        try:
            parser.parse_args(shlex.split(command)[1:])
        except SystemExit as stop:
            pytest.fail(f"{document.name}: `{command}` does not parse (exit {stop.code})")


def test_every_command_not_run_is_still_documented():
    documented = {c for d in DOCUMENTS for c in commands(d)}
    assert set(NOT_RUN) <= documented, set(NOT_RUN) - documented


def test_make_demo_runs_the_tested_command():
    recipe = re.search(r"^demo:.*\n\t(.*)$", (ROOT / "Makefile").read_text(), flags=re.M)
    assert recipe.group(1) == "$(BIN)/glarelab demo --protocol yoshida2008 --out out/demo"
    test = (ROOT / "tests" / "test_demo.py").read_text()
    assert '"demo", "--protocol", "yoshida2008", "--out"' in test


def fresh_clone(folder: Path) -> Path:
    """The repository's tracked files, as a clone has them (no .venv, no outputs)."""
    listed = subprocess.run(
        ["git", "-C", str(ROOT), "ls-files", "-z"], capture_output=True, check=False
    )
    if listed.returncode != 0:
        pytest.fail(f"the docs test copies the repository's tracked files: {listed.stderr!r}")
    for name in filter(None, listed.stdout.decode().split("\0")):
        source = ROOT / name
        if source.is_file():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, folder / name)
    return folder


def home_env(clone: Path) -> dict:
    """The environment of the documents' commands: a home folder of the clone's own, so that
    what a command writes there (PsychoPy's Monitor Center, ~/.psychopy3) is not the user's."""
    home = clone.parent / "home"
    home.mkdir(exist_ok=True)
    return {**os.environ, "HOME": str(home)}


def glarelab(*args, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "glarelab", *map(str, args)],
        env=home_env(cwd),
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )


def fill_placeholders(words: list[str], clone: Path) -> list[str]:
    """The shipped examples in place of what a lab brings: photometer readings, and sessions
    run by participants (simulated observers in their stead, three of them). Calibrations and
    stimulus sets are not filled in: each document makes them with its own commands, as
    printed, before it reads them."""
    if "readings.csv" in words and not (clone / "readings.csv").exists():
        shutil.copy(clone / "calibrations" / "example-readings.csv", clone / "readings.csv")
    if words[1] == "analyse":
        study = words[2]
        pattern = next(w for w in words[3:] if w.endswith(".csv"))
        if not glob.glob(str(clone / pattern)):
            extra = []
            if "--stimuli" in words:
                extra = ["--stimuli", words[words.index("--stimuli") + 1]]
            done = glarelab(
                "run", study, "--simulate", "--participants", 3, "--seed", 1, *extra,
                "--out", Path(pattern).parent, cwd=clone,
            )  # fmt: skip
            assert done.returncode == 0, done.stderr
    expanded = []
    for word in words:
        matches = sorted(glob.glob(str(clone / word))) if any(c in word for c in "*?") else []
        expanded += [str(Path(m).relative_to(clone)) for m in matches] or [word]
    return expanded


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_documented_commands_run_in_a_fresh_clone(document, tmp_path):
    clone = fresh_clone(tmp_path / "clone")
    ran = []
    for command in commands(document):
        if command in NOT_RUN:
            continue
        if not command.startswith("glarelab "):
            if command.startswith("make "):
                pytest.fail(f"{document.name}: `{command}`: say in NOT_RUN how it is tested")
            done = subprocess.run(
                ["bash", "-c", command],
                cwd=clone,
                env=home_env(clone),
                capture_output=True,
                text=True,
                check=False,
            )
            assert done.returncode == 0, f"{document.name}: `{command}`: {done.stderr}"
            ran.append(command)
            continue
        words = fill_placeholders(shlex.split(command), clone)
        if words[1] == "power":
            # a documented run is a thousand replications on every core: the same command on
            # two, without a cluster (tests/planning check the estimates themselves)
            # (given once: a flag given twice is refused)
            for flag, value in (("--replications", "2"), ("--workers", "0")):
                if flag in words:
                    words[words.index(flag) + 1] = value
                else:
                    words += [flag, value]
        argv = [sys.executable, "-m", "glarelab", *words[1:]]
        if "--scripted-keys" in words:
            argv += [] if "--pilot" in words else ON_XVFB  # a pilot accepts the screen itself
            if not os.environ.get("DISPLAY"):
                argv = [*XVFB, *argv]
        if words[1] == "check-display" and not os.environ.get("DISPLAY"):
            argv = [*XVFB, *argv]
        done = subprocess.run(
            argv,
            cwd=clone,
            env=home_env(clone),
            capture_output=True,
            text=True,
            timeout=900,
            check=False,
        )
        if words[1] == "check-display":
            for run in (1, 2):  # as printed, then again (after a driver change)
                failed = [
                    line.split()[1].rstrip(":")
                    for line in done.stdout.splitlines()
                    if line.strip().startswith("FAIL")
                ]
                assert done.returncode == 1 and set(failed) <= XVFB_FAILS, (
                    f"{document.name}: `{command}` (run {run}) exited {done.returncode} with "
                    f"FAIL {failed}:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
                )
                assert "read back" in done.stdout and " ok   " in done.stdout, done.stdout
                if run == 1:
                    done = subprocess.run(
                        argv,
                        cwd=clone,
                        env=home_env(clone),
                        capture_output=True,
                        text=True,
                        timeout=900,
                        check=False,
                    )
            ran.append(command)
            continue
        expected = next((s for flag, s in EXIT_STATUS.items() if flag in words), 0)
        assert done.returncode == expected, (
            f"{document.name}: `{command}` exited {done.returncode}, not {expected}:\n"
            f"{done.stderr[-3000:]}"
        )
        ran.append(command)
    expected_to_run = [c for c in commands(document) if c not in NOT_RUN]
    assert ran == expected_to_run
