"""Running a session: checks before the first trial, then every trial on disk as it ends.

Before any trial runs (and before any file is created) a session refuses: a participant id
that is not file-name safe or whose session already has data (unless resuming); a stimulus set
that fails its manifest or was built from another protocol; a missing, failed or synthetic
calibration unless the session is explicitly uncalibrated. Then the sidecar is written
(status ``running``), each finished trial is appended and fsync'ed, and the sidecar ends as
``completed`` or ``aborted`` (Escape). Simulated sessions take the same path with an observer
for a front-end.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from pathlib import Path

from stimuli.calibration import Calibration, usable_calibration
from stimuli.stimulus_set import package_versions, verify_stimulus_set

from .data import SessionFiles, session_paths
from .luidolt2020 import LikertQuestionnaire
from .observers import SimulatedObserver
from .spencer1995 import StaircaseExperiment
from .yoshida2008 import BrightnessMatching

__all__ = ["SimulatedFrontend", "counterbalance_for", "make_engine", "run_session"]

STUDIES_WITH_STIMULI = ("yoshida2008", "spencer1995")
PACKAGES = ("numpy", "scipy", "OpenEXR", "colour-science", "psychopy", "glarelab")


class SessionAborted(Exception):
    """Raised by a front-end when the participant presses Escape."""


def counterbalance_for(participant: str) -> int:
    """Block order of a participant from the number in their id: odd → 0 (no context first),
    even → 1 (context first), so consecutive participants alternate."""
    digits = re.findall(r"\d+", participant)
    if not digits:
        raise ValueError(
            f"participant {participant!r} has no number to counterbalance by; "
            "give --counterbalance 0 or 1"
        )
    return 0 if int(digits[-1]) % 2 == 1 else 1


def make_engine(
    protocol, participant: str, *, session: int, counterbalance: int | None, refresh_hz: float
):
    if protocol.study == "yoshida2008":
        return BrightnessMatching(protocol, participant, session=session)
    if protocol.study == "spencer1995":
        cb = counterbalance_for(participant) if counterbalance is None else counterbalance
        return StaircaseExperiment(
            protocol, participant, session=session, counterbalance=cb, refresh_hz=refresh_hz
        )
    if protocol.study == "luidolt2020":
        return LikertQuestionnaire(protocol, participant, session=session)
    raise ValueError(f"no experiment for study {protocol.study!r}")


class SimulatedFrontend:
    """Drives an engine with a simulated observer's key presses (no screen)."""

    bit_depth = None
    refresh_hz = 60.0

    def __init__(self, observer: SimulatedObserver, *, trial_delay_s: float = 0.0):
        self.observer = observer
        self.trial_delay_s = trial_delay_s

    def run(self, engine, on_row) -> None:
        while not engine.done:
            for key, t in self.observer.keys(engine.screen()):
                row = engine.press(key, t)
                if row is not None:
                    on_row(row)
                    if self.trial_delay_s:
                        time.sleep(self.trial_delay_s)


def _check_stimuli(protocol, stimuli: Path | None) -> str | None:
    if protocol.study not in STUDIES_WITH_STIMULI:
        return None
    if stimuli is None:
        raise ValueError(f"a {protocol.study} session needs its stimulus set (--stimuli DIR)")
    problems = verify_stimulus_set(stimuli)
    if problems:
        raise ValueError(
            f"the stimulus set {stimuli} fails its manifest: " + "; ".join(problems[:5])
        )
    manifest = json.loads((Path(stimuli) / "manifest.json").read_text())
    if manifest.get("protocol_sha256") != protocol.sha256:
        raise ValueError(
            f"the stimulus set {stimuli} was built from another protocol (sha256 "
            f"{manifest.get('protocol_sha256', '?')[:12]}…, this one {protocol.sha256[:12]}…); "
            "rebuild it with glarelab stimuli build"
        )
    return hashlib.sha256((Path(stimuli) / "manifest.json").read_bytes()).hexdigest()


def run_session(
    protocol,
    participant: str,
    *,
    out: Path,
    frontend,
    session: int = 1,
    stimuli: Path | None = None,
    calibration: Calibration | None = None,
    allow_uncalibrated: bool = False,
    resume: bool = False,
    counterbalance: int | None = None,
    participant_info: dict | None = None,
    simulated: bool = False,
) -> dict:
    """Run (or resume) one session; return its sidecar.

    Raises
    ------
    ValueError
        Before any trial runs: see the module notes.
    """
    csv_path, sidecar_path = session_paths(out, protocol.study, participant, session)
    if not resume and (csv_path.exists() or sidecar_path.exists()):
        raise ValueError(
            f"{csv_path} exists: participant {participant!r} session {session} already has data; "
            "use another session number, or --resume to continue it"
        )
    manifest_sha = _check_stimuli(protocol, stimuli) if not simulated else None
    calibration_record = (
        {"calibrated": False, "status": "simulated", "readings_sha256": None}
        if simulated
        else usable_calibration(calibration, allow_uncalibrated=allow_uncalibrated)
    )
    if hasattr(frontend, "open"):
        frontend.open()  # after every check, before any file: a failing window leaves no data
    try:
        files = SessionFiles(protocol.study, participant, session, Path(out), resume=resume)
    except Exception:
        if hasattr(frontend, "close"):
            frontend.close()
        raise
    engine = make_engine(
        protocol,
        participant,
        session=session,
        counterbalance=counterbalance,
        refresh_hz=frontend.refresh_hz,
    )
    sidecar = files.read_sidecar() if resume else {}
    sidecar.update(
        {
            "study": protocol.study,
            "participant": participant,
            "session": session,
            "participant_info": participant_info or sidecar.get("participant_info", {}),
            "protocol_sha256": protocol.sha256,
            "stimulus_set_manifest_sha256": manifest_sha,
            "calibration": calibration_record,
            "packages": package_versions(PACKAGES),
            "refresh_hz": frontend.refresh_hz,
            "bit_depth": frontend.bit_depth,
            "simulated": simulated,
            "images_encoded_with": getattr(frontend, "calibration_used", None),
            "counterbalance": getattr(engine, "counterbalance", None),
            "trial_order": getattr(engine, "order", None),
            "status": "running",
            "resumed": sidecar.get("resumed", 0) + (1 if resume else 0),
        }
    )
    files.write_sidecar(sidecar)
    if resume:
        engine.replay(files.rows)
    status = "completed"
    try:
        frontend.run(engine, files.write_row)
    except SessionAborted:
        status = "aborted"
    finally:
        sidecar.update(
            {
                "status": status if engine.done or status == "aborted" else "aborted",
                "trials": len(files.rows),
                "refresh_hz": frontend.refresh_hz,
                "bit_depth": frontend.bit_depth,
            }
        )
        files.write_sidecar(sidecar)
        files.close()
    return sidecar
