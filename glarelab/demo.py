"""``glarelab demo``: a whole study on simulated observers, from protocol to report.

The steps a lab takes, with simulated observers in place of participants: build the stimulus
set from the protocol with the shipped synthetic calibration (and verify it), run the
participants through the same protocol engine a lab session uses, analyse their CSVs, and
write ``report.html``. The output folder is the demo's own and is replaced on each run.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path

from analysis.report import write_report
from experiments.observers import SimulatedObserver
from experiments.session import SimulatedFrontend, run_session
from stimuli.calibration import Calibration
from stimuli.protocol import load_protocol
from stimuli.stimulus_set import build_stimulus_set, verify_stimulus_set

__all__ = ["PROTOCOLS", "run_demo"]

ROOT = Path(__file__).resolve().parents[1]
PROTOCOLS = ROOT / "protocols"
CALIBRATIONS = {
    "yoshida2008": ROOT / "calibrations" / "SYNTHETIC-yoshida2008-433cd-10bit.json",
    "spencer1995": ROOT / "calibrations" / "SYNTHETIC-spencer1995-100cd-8bit.json",
}


def run_demo(
    study: str,
    out: str | Path,
    *,
    participants: int = 10,
    seed: int = 1,
    log: Callable[[str], None] = print,
) -> Path:
    """Run the demo of one study into ``out`` and return the report's path."""
    out = Path(out)
    protocol_path = PROTOCOLS / f"{study}.toml"
    protocol = load_protocol(protocol_path)
    for part in ("stimuli", "data", "report"):  # the demo's own output, rebuilt every time
        shutil.rmtree(out / part, ignore_errors=True)
    steps = 4 if study in CALIBRATIONS else 3
    step = 0
    stimuli = None
    if study in CALIBRATIONS:
        step += 1
        log(f"[{step}/{steps}] building the {study} stimulus set (synthetic calibration)")
        build_stimulus_set(
            protocol, out / "stimuli", calibration=Calibration.load(CALIBRATIONS[study])
        )
        problems = verify_stimulus_set(out / "stimuli")
        if problems:
            raise ValueError(f"the demo's stimulus set does not verify: {problems}")
        stimuli = out / "stimuli"
    step += 1
    log(f"[{step}/{steps}] running {participants} simulated observers (seed {seed})")
    for number in range(1, participants + 1):
        participant = f"sim{number:02d}"
        frontend = SimulatedFrontend(SimulatedObserver(protocol, participant, seed=seed))
        run_session(
            protocol,
            participant,
            out=out / "data",
            frontend=frontend,
            simulated=True,
            participant_info={"simulated_observer_seed": seed},
        )
        log(f"      {number}/{participants} {participant}")
    step += 1
    log(f"[{step}/{steps}] analysing")
    csvs = sorted((out / "data").glob(f"*_{study}_s*.csv"))
    report = write_report(study, csvs, out / "report", protocol=protocol, stimuli=stimuli)
    step += 1
    log(f"[{step}/{steps}] report written: {report}")
    return report
