"""``glarelab demo``: a whole study on simulated observers, from protocol to report.

The steps a lab takes, with simulated observers in place of participants: build the stimulus
set from the protocol with its display's synthetic calibration (and verify it), run the
participants through the same session loop a lab session uses, analyse their CSVs, and write
``report.html``. The output folder is the demo's own: its stimuli, data and report are
replaced on each run, and a folder the demo did not make (or one holding a session that is not
simulated) is refused untouched.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path

from analysis.report import write_report
from experiments.session import SimulatedFrontend, make_observer, run_session, shows_images
from protocols import load_protocol
from stimuli.stimulus_set import build_stimulus_set, default_calibration, verify_stimulus_set

__all__ = ["run_demo"]


MARKER = ".glarelab-demo"  # marks a folder the demo made, so a rerun may replace its output


def _check_own(out: Path) -> None:
    """Refuse a folder the demo did not make, and one where anything but simulated sessions
    has been recorded since: the demo replaces its folder's stimuli, data and report."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; the demo needs a folder")
    if not out.is_dir() or not any(out.iterdir()):
        return
    if not (out / MARKER).is_file():
        raise ValueError(
            f"--out {out} holds files the demo did not write; the demo replaces its output "
            "folder's stimuli, data and report, so give a new or empty folder (nothing was "
            "changed)"
        )
    for sidecar in sorted((out / "data").glob("*.json")):
        try:
            simulated = json.loads(sidecar.read_text()).get("simulated") is True
        except (ValueError, AttributeError, OSError):
            simulated = False
        if not simulated:
            raise ValueError(
                f"--out {out}: {sidecar} is not a simulated session; the demo would delete it "
                "with its data folder, so give another folder (nothing was changed)"
            )
    others = (
        [
            p
            for p in (out / "data").iterdir()
            if p.suffix not in (".csv", ".json", ".log", ".tsv", ".lock")
        ]
        if (out / "data").is_dir()
        else []
    )
    if others:
        raise ValueError(
            f"--out {out}: {others[0]} is not a file the demo writes; give another folder "
            "(nothing was changed)"
        )


def run_demo(
    protocol_name: str | Path,
    out: str | Path,
    *,
    participants: int = 10,
    seed: int = 1,
    log: Callable[[str], None] = print,
) -> Path:
    """Run the demo of one protocol (a shipped name or a TOML file) into ``out``; return the
    report's path."""
    out = Path(out)
    protocol = load_protocol(protocol_name)
    _check_own(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / MARKER).write_text("demo\n")
    for part in ("stimuli", "data", "report"):  # the demo's own output, rebuilt every time
        shutil.rmtree(out / part, ignore_errors=True)
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
        log(f"      {number}/{participants} {participant}")
    step += 1
    log(f"[{step}/{steps}] analysing")
    csvs = sorted((out / "data").glob(f"*_{protocol.study}_s*.csv"))
    report = write_report(protocol, csvs, out / "report", stimuli=stimuli)
    step += 1
    log(f"[{step}/{steps}] report written: {report}")
    return report
