"""``glarelab demo``: a whole study on simulated observers, from protocol to report.

The steps a lab takes, with simulated observers in place of participants: build the stimulus
set from the protocol with its display's synthetic calibration (and verify it), run the
participants through the same session loop a lab session uses, analyse their CSVs, and write
``report.html``. The output folder is the demo's own: its stimuli, data and report are
replaced on each run, and a folder holding any file the demo did not write there (a
participant's session, a user's notes, a link to another folder) is refused untouched
(:mod:`glarelab.files.folders`).
"""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Callable
from pathlib import Path

from glarelab.analysis.report import write_report
from glarelab.experiments.session import (
    SimulatedFrontend,
    make_observer,
    run_session,
)
from glarelab.files.folders import LISTING, check_replaceable, record_files
from glarelab.protocols import load_protocol
from glarelab.stimuli.stimulus_set import (
    build_stimulus_set,
    default_calibration,
    shows_images,
    verify_stimulus_set,
)

__all__ = ["run_demo"]

KIND = "demo"  # the kind of output in the folder's listing of files glarelab wrote


def run_demo(
    protocol_name: str | Path,
    out: str | Path,
    *,
    participants: int = 10,
    seed: int = 1,
    log: Callable[[str], None] = print,
) -> Path:
    """Run the demo of one protocol (a shipped name or a TOML file) into ``out``; return the
    report's path.

    Parameters
    ----------
    protocol_name
        A shipped study's name or a protocol TOML file.
    out
        The demo folder: ``stimuli/``, ``data/`` and ``report/`` in it are rebuilt; a folder
        holding other files is refused.
    participants
        Simulated observers, each one session; default 10.
    seed
        The simulated observers' seed; default 1.
    log
        Called with each step's progress line; default :func:`print`.

    Returns
    -------
    pathlib.Path
        The report's path, as :func:`glarelab.analysis.report.write_report` returns it.

    Raises
    ------
    ValueError
        For a folder holding files the demo did not write, or a stimulus set that does not
        verify.
    """
    out = Path(out)
    protocol = load_protocol(protocol_name)
    check_replaceable(out, kind=KIND, what="demo folder")
    created = not (out.exists() or out.is_symlink())
    out.mkdir(parents=True, exist_ok=True)
    for part in ("stimuli", "data", "report"):  # the demo's own output, rebuilt every time
        shutil.rmtree(out / part, ignore_errors=True)
    record_files(out, KIND)
    try:
        return _run(protocol, out, participants=participants, seed=seed, log=log)
    except BaseException:
        if created and {p.name for p in out.iterdir()} <= {LISTING}:
            # a first run that failed (a full disk) leaves no folder holding only a listing
            (out / LISTING).unlink(missing_ok=True)
            with contextlib.suppress(OSError):
                out.rmdir()
        raise


def _run(protocol, out: Path, *, participants: int, seed: int, log) -> Path:
    """:func:`run_demo` in its folder, made and listed."""
    images = shows_images(protocol)
    steps = 4 if images else 3
    step = 0
    stimuli = None
    if images:
        step += 1
        log(f"[{step}/{steps}] building the {protocol.study} stimulus set (synthetic calibration)")
        build_stimulus_set(protocol, out / "stimuli", calibration=default_calibration(protocol))
        problems = verify_stimulus_set(out / "stimuli")
        if problems:
            raise ValueError(f"the demo's stimulus set does not verify: {problems}")
        stimuli = out / "stimuli"
        record_files(out, KIND)
    step += 1
    log(f"[{step}/{steps}] running {participants} simulated observers (seed {seed})")
    for number in range(1, participants + 1):
        participant = f"sim{number:02d}"
        observer = make_observer(protocol, participant, seed=seed, stimuli=stimuli)
        run_session(
            protocol,
            participant,
            out=out / "data",
            frontend=SimulatedFrontend(observer),
            stimuli=stimuli,
            simulated=True,
            participant_info={"simulated_observer_seed": seed},
        )
        record_files(out, KIND)
        log(f"      {number}/{participants} {participant}")
    step += 1
    log(f"[{step}/{steps}] analysing")
    csvs = sorted((out / "data").glob(f"*_{protocol.study}_s*.csv"))
    report = write_report(protocol, csvs, out / "report", stimuli=stimuli)
    record_files(out, KIND)
    step += 1
    log(f"[{step}/{steps}] report written: {report}")
    return report
