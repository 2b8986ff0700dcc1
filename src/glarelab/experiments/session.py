"""Running a session: every check before the first trial, then every trial on disk as it ends.

In order, before any file is written:

1. the participant id and session number are file-name safe, and the session is not held by
   another process, whatever its output folder (a lock, see :mod:`glarelab.experiments.data`);
2. a new session has no files yet; a resumed one has its CSV with a valid header and its
   sidecar, and the protocol, stimulus set and calibration are the ones it started with, and
   the participant's details given now do not contradict the stored ones;
3. the stimulus set matches its manifest and was built from this protocol; the calibration is
   usable (not missing, failed or synthetic unless the session is explicitly uncalibrated) and
   is this display's (:func:`glarelab.display.checks.check_calibration`);
4. the window opens and its resolution, refresh rate and bits per channel are the protocol's
   (:func:`glarelab.display.checks.check_screen`), unless a mismatch is accepted.

Then the CSV header and the sidecar (status ``running``, start time) are written and fsync'ed,
and :class:`glarelab.experiments.loop.SessionLoop` runs the trials, each row fsync'ed as it ends.
The sidecar ends as ``completed`` or ``aborted`` (Escape, SIGINT, SIGTERM, SIGHUP), with the end
time; a session ended before its first trial keeps its header, log and sidecar (``aborted``). A
session killed outright keeps its rows and a ``running`` sidecar; resuming it records that run
as ``interrupted``, its end unknown (``ended`` null), with its trials counted from the CSV and
the last write of its files. Simulated sessions take the same path with a simulated device.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import signal
import socket
import sys
import threading
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

from glarelab.display.calibration import Calibration, usable_calibration
from glarelab.display.checks import check_calibration, check_screen, enforce, timing_rate_hz
from glarelab.experiments.data import (
    SessionError,
    SessionFiles,
    SessionLock,
    WriteFault,
    check_session_id,
)
from glarelab.experiments.engine import Press, first_screen
from glarelab.experiments.loop import SessionAborted, SessionLoop, Shown
from glarelab.experiments.paradigms import paradigm_run
from glarelab.protocols import DATA_FORMAT
from glarelab.stimuli.stimulus_set import (
    check_set_protocol,
    package_versions,
    prove_stimulus_set,
    shows_images,
)

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = [
    "SessionAborted",
    "SimulatedFrontend",
    "check_completed_session",
    "check_counterbalance",
    "make_engine",
    "make_observer",
    "run_session",
]

PACKAGES = ("numpy", "scipy", "OpenEXR", "colour-science", "psychopy", "glarelab")
INFO_KEYS = ("age", "sex", "vision_correction")
END_TEXT = "The session is complete. Thank you!\n\nPlease tell the experimenter."


def check_counterbalance(protocol: Protocol, counterbalance: int | None) -> None:
    """Refuse a block order for a paradigm without blocks to order.

    Parameters
    ----------
    protocol
        The study's protocol.
    counterbalance
        The block order asked for; None: none asked for (always accepted).

    Raises
    ------
    ValueError
        For a ``counterbalance`` given to a paradigm whose engine does not order blocks by it
        (:attr:`glarelab.experiments.engine.Engine.counterbalanced`), saying how it orders
        the trials (:meth:`glarelab.experiments.engine.Engine.ordered`).

    Examples
    --------
    >>> from glarelab.protocols import load_protocol
    >>> check_counterbalance(load_protocol("spencer1995"), 1)
    >>> check_counterbalance(load_protocol("luidolt2020"), None)
    """
    engine = paradigm_run(protocol).engine
    if counterbalance is not None and not engine.counterbalanced:
        order = engine.ordered(protocol)
        raise ValueError(
            f"--counterbalance {counterbalance}: the {protocol.study} protocol's paradigm "
            f"({protocol.paradigm}) has no blocks to order{f' ({order})' if order else ''}; "
            "give no --counterbalance"
        )


def make_engine(
    protocol: Protocol,
    participant: str,
    *,
    session: int,
    counterbalance: int | None,
    refresh_hz: float,
):
    """The engine of the protocol's paradigm for one participant's session.

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol.
    participant
        The participant's id.
    session
        The session's number, from 1.
    counterbalance
        The block order, where the paradigm has one (0 or 1); None: from the participant.
    refresh_hz
        The display's refresh rate, Hz, which timed presentations are counted in.

    Returns
    -------
    glarelab.experiments.engine.Engine
        A new engine (:func:`glarelab.experiments.paradigms.paradigm_run`).
    """
    return paradigm_run(protocol).engine(
        protocol,
        participant,
        session=session,
        counterbalance=counterbalance,
        refresh_hz=refresh_hz,
    )


def make_observer(protocol: Protocol, participant: str, *, seed: int, stimuli):
    """A simulated observer of the protocol's paradigm; it looks at the set in ``stimuli`` (a
    folder, or an :class:`glarelab.observers.looking.ObservedSet` that observers share, and with
    it their percepts).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol.
    participant
        The simulated participant's id.
    seed
        The simulated observers' seed.
    stimuli
        The set's folder, a shared displayed set, or None for a protocol that shows no
        images.

    Returns
    -------
    object
        The paradigm's observer (its ``keys(screen)`` answers the screens).

    Raises
    ------
    ValueError
        For a paradigm without a simulated observer, or no set where images are shown.
    """
    from glarelab.observers.looking import ObservedSet
    from glarelab.stimuli.stimulus_set import StimulusSet

    observer = paradigm_run(protocol).observer
    if observer is None:
        raise ValueError(f"the {protocol.paradigm} paradigm has no simulated observer")
    if shows_images(protocol) and stimuli is None:
        raise ValueError(
            f"a simulated {protocol.study} observer needs the stimulus set to look at"
        )
    if stimuli is not None and not isinstance(stimuli, ObservedSet):
        check_set_protocol(protocol, Path(stimuli))
    return observer(
        protocol,
        participant,
        seed=seed,
        stimuli=stimuli
        if stimuli is None or isinstance(stimuli, ObservedSet)
        else StimulusSet(stimuli),
    )


def _tick(seconds: float) -> float:
    """A time on the simulated clock's grid of 2⁻²⁰ s (about 1 µs): sums and differences of
    such times are exact, so a trial's times do not depend on when it ran (a resumed
    simulation writes the rows an uninterrupted one does)."""
    return round(seconds * 2**20) / 2**20


class SimulatedFrontend:
    """A device driven by a simulated observer's key presses, on a virtual clock (no screen).

    Screens that wait for the space bar (instructions, breaks) are answered after a second;
    trial screens by the observer, with its times from the trial's onset.

    Parameters
    ----------
    observer
        The simulated observer (:func:`make_observer`).
    trial_delay_s
        Real seconds to wait before each trial's answer, default 0 (for tests that stop a
        session part way).
    """

    keyboard = "simulated observer"
    calibration_used = None

    def __init__(self, observer, *, trial_delay_s: float = 0.0):
        self.observer = observer
        self.trial_delay_s = trial_delay_s
        self.clock = 0.0
        self.refresh_hz = 60.0
        self.screen: dict | None = None

    def open(self):
        return None

    def start(
        self,
        *,
        run: int = 1,
        started: str = "",
        refresh_hz: float,
        pace: bool,
        frames_path,
        log_path,
    ) -> None:
        """Begin a run: only the refresh rate is kept (nothing is shown or written).

        Parameters
        ----------
        run
            The run's number within the session; not used.
        started
            When the run started; not used.
        refresh_hz
            The refresh rate the virtual clock counts timed presentations in, Hz.
        pace
            Whether to pace frames by the clock; not used (the clock is virtual).
        frames_path, log_path
            Where a screen would write its frame times and log; not used.
        """
        self.refresh_hz = refresh_hz

    def close(self) -> None:
        pass

    def log(self, message: str) -> None:
        """Log a line (nothing: a simulated run has no log).

        Parameters
        ----------
        message
            Not used: a simulated run writes no PsychoPy log.
        """
        pass

    def clock_epoch_s(self) -> float | None:
        return None

    def show(self, screen: dict) -> float:
        """Show a screen on the virtual clock.

        Parameters
        ----------
        screen
            The screen, kept for :meth:`wait_keys`.

        Returns
        -------
        float
            The virtual onset, s: a millisecond after the last event.
        """
        self.screen = screen
        self.clock += _tick(0.001)
        return self.clock

    def present(self, screen: dict) -> Shown:
        """Show a timed presentation on the virtual clock.

        Parameters
        ----------
        screen
            The timed screen (``frames``, ``blank_before_ms``), kept for :meth:`wait_keys`.

        Returns
        -------
        glarelab.experiments.loop.Shown
            Its virtual onset and offset, no frame dropped.
        """
        self.screen = screen
        onset = self.clock + _tick(screen.get("blank_before_ms", 0.0) / 1000.0)
        self.clock = onset + _tick(screen["frames"] / self.refresh_hz)
        return Shown(onset_s=onset, offset_s=self.clock, frames=screen["frames"])

    def typed(self) -> str:
        return ""  # simulated observers comment on nothing

    def wait_keys(self, anchor_s: float) -> list[Press]:
        """The presses that answer the screen shown last, on the virtual clock.

        Parameters
        ----------
        anchor_s
            The onset the presses are timed from, s on the virtual clock.

        Returns
        -------
        list of glarelab.experiments.engine.Press
            The observer's presses on a trial screen, or Space a second after the onset on
            another.

        Raises
        ------
        RuntimeError
            When the observer has no answer to the screen.
        """
        screen = self.screen
        if "trial" in screen:
            keys = self.observer.keys(screen)
            if self.trial_delay_s:
                time.sleep(self.trial_delay_s)
        else:
            keys = [("space", 1.0)]
        if not keys:
            raise RuntimeError(
                f"the simulated observer has no answer to a {screen['kind']} screen"
            )
        presses = [Press(key, anchor_s + _tick(t)) for key, t in keys]
        self.clock = max(self.clock, *(p.t_s for p in presses))
        return presses


def _check_stimuli(protocol: Protocol, stimuli: Path | None) -> str | None:
    if not shows_images(protocol):
        return None
    if stimuli is None:
        raise ValueError(f"a {protocol.study} session needs its stimulus set (--stimuli DIR)")
    problems = prove_stimulus_set(stimuli)
    if problems:
        raise ValueError(
            f"the stimulus set {stimuli} fails its manifest: " + "; ".join(problems[:5])
        )
    check_set_protocol(protocol, Path(stimuli))
    return hashlib.sha256((Path(stimuli) / "manifest.json").read_bytes()).hexdigest()


def _check_set_in_use(frontend, stimuli: Path | None, manifest_sha: str | None) -> None:
    """The set the front-end shows is the one verified: a set rebuilt between the check and
    the window's opening is refused (a change during the session is refused by its reads,
    :class:`glarelab.stimuli.stimulus_set.StimulusSet`)."""
    held = getattr(getattr(frontend, "images", None), "set", None)
    if held is None:
        display = getattr(getattr(frontend, "observer", None), "display", None)
        held = getattr(display, "set", None)
    shown = getattr(held, "manifest_sha256", None)
    if manifest_sha is not None and shown is not None and shown != manifest_sha:
        raise SessionError(
            f"the stimulus set {stimuli} changed while the session started (its manifest is "
            "not the one verified): it was rebuilt or edited; start the session again"
        )


def _now() -> datetime:
    return datetime.now().astimezone()


def _iso(moment: datetime) -> str:
    return moment.isoformat(timespec="seconds")


def _rows_changed(sidecar: dict, files: SessionFiles) -> str | None:
    """What differs between the CSV's rows and those the session wrote (its sidecar's
    ``row_sha256``, data format 0.5 on): the first row changed, or fewer rows; None if none."""
    recorded = sidecar.get("row_sha256")
    if not isinstance(recorded, list):
        return None
    rows = files.row_digests()
    pairs = zip(rows, recorded, strict=False)  # rows after the last: a killed run's
    edited = [n for n, (a, b) in enumerate(pairs, start=1) if a != b]
    if edited:
        return f"trial {edited[0]} is not the row the session wrote (changed since?)"
    if len(rows) < len(recorded):
        return f"it holds {len(rows)} trials, the session recorded {len(recorded)}"
    return None


def _check_completed_rows(
    sidecar: dict, files: SessionFiles, advice: str = "start a new session number"
) -> None:
    """Refuse a completed session whose CSV lost trials it recorded."""
    recorded, held = sidecar.get("trials"), len(files.rows)
    if isinstance(recorded, int) and not isinstance(recorded, bool) and held < recorded:
        missing = f"{held + 1}" if held + 1 == recorded else f"{held + 1}-{recorded}"
        raise SessionError(
            f"{files.csv_path.name}: trial{'s' if held + 1 < recorded else ''} {missing} "
            f"of the {recorded} the completed session recorded missing (rows deleted, or "
            "the file cut short?); a completed session is not resumed: put its rows back "
            f"from a copy of the file, or keep it for the record and {advice}"
        )


def check_completed_session(
    protocol: Protocol, participant: str, *, out: Path, session: int, pilot: bool = False
) -> None:
    """Refuse a completed session whose CSV no longer holds the rows it wrote: a batch that
    goes on (``run --simulate --resume``) keeps it only as it was.

    Parameters
    ----------
    protocol, participant
        The study and the participant's id.
    out
        The folder of the session's files.
    session
        The session's number.
    pilot
        Whether it is a pilot session; default False.

    Raises
    ------
    SessionError
        Naming the CSV and its first trial missing or changed.
    """
    files = SessionFiles(
        protocol, participant, session, Path(out), resume=True, started=_now(), pilot=pilot
    )
    try:
        sidecar = files.read_sidecar()
        _check_completed_rows(sidecar, files, "give another --out")
        what = _rows_changed(sidecar, files)
        if what is not None:
            raise SessionError(
                f"{files.csv_path.name}: {what}; a completed session is kept only with the "
                "rows it wrote: put them back from a copy of the file, or keep it for the "
                "record and give another --out"
            )
    finally:
        files.close()


def _check_resume(
    sidecar: dict,
    files: SessionFiles,
    protocol: Protocol,
    manifest_sha,
    calibration_record,
    info: dict,
    counterbalance: int | None,
) -> tuple[dict, int | None]:
    """Refuse a resume whose inputs changed; return the participant's details to keep and the
    counterbalance the session started with."""
    if not sidecar:
        raise SessionError(
            f"{files.sidecar_path} is missing: without it the session cannot be checked "
            "against its protocol, stimulus set and calibration, so it is not resumed; start "
            "a new session number"
        )
    if sidecar.get("status") == "completed":
        _check_completed_rows(sidecar, files)
        raise SessionError(
            f"{files.csv_path.name} is a completed session: there is nothing to resume"
        )
    what = _rows_changed(sidecar, files)
    if what is not None:
        raise SessionError(
            f"{files.csv_path.name}: {what}; a session is resumed only with the rows it "
            "wrote: keep the file for the record and start a new session number"
        )
    changed = []
    for what, key, now in (
        ("protocol", "protocol_sha256", protocol.sha256),
        ("stimulus set", "stimulus_set_manifest_sha256", manifest_sha),
    ):
        if sidecar.get(key) != now:
            changed.append(
                f"the {what} (sha256 {str(sidecar.get(key))[:12]}… then, {str(now)[:12]}… now)"
            )
    recorded = sidecar.get("calibration") or {}
    # the curve's digest where the session recorded it (a refit of the same readings by another
    # method encodes otherwise), else the readings' (sessions before it was recorded)
    key = "curve_sha256" if "curve_sha256" in recorded else "readings_sha256"
    before = recorded.get(key)
    if before != calibration_record[key]:
        what = "curve" if key == "curve_sha256" else "readings"
        changed.append(
            f"the calibration ({what} sha256 {str(before)[:12]}… then, "
            f"{str(calibration_record[key])[:12]}… now)"
        )
    if changed:
        raise SessionError(
            f"{files.csv_path.name} was started with other inputs: "
            + "; ".join(changed)
            + ". A session is resumed only with what it started with"
        )
    stored = dict(sidecar.get("participant_info") or {})
    conflicts = [
        f"{key} {value!r} (stored: {stored[key]!r})"
        for key, value in info.items()
        if value is not None and stored.get(key) is not None and stored[key] != value
    ]
    if conflicts:
        raise SessionError(
            f"the participant's details given now contradict those stored in "
            f"{files.sidecar_path.name}: {', '.join(conflicts)}; resume without them, or check "
            "the participant id"
        )
    started_with = sidecar.get("counterbalance")
    if counterbalance is not None and started_with is not None and counterbalance != started_with:
        raise SessionError(
            f"--counterbalance {counterbalance} contradicts the {started_with} "
            f"{files.csv_path.name} started with; resume without it"
        )
    keep = counterbalance if counterbalance is not None else started_with
    return stored | {k: v for k, v in info.items() if v is not None}, keep


@contextlib.contextmanager
def _signals(handler):
    """SIGINT, SIGTERM and SIGHUP go to ``handler`` within the block (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    names = ("SIGINT", "SIGTERM", "SIGHUP")
    numbers = [getattr(signal, n) for n in names if hasattr(signal, n)]
    previous = {n: signal.signal(n, handler) for n in numbers}
    try:
        yield
    finally:
        for number, old in previous.items():
            signal.signal(number, old)


@contextlib.contextmanager
def _signals_deferred():
    """SIGINT, SIGTERM and SIGHUP held while the block runs (a sidecar's end is written
    whole), then delivered to the handlers in place after it: a Ctrl-C then is not lost."""
    held: list[int] = []
    with _signals(lambda number, frame: held.append(number)):
        yield
    if held:
        signal.raise_signal(held[0])


class _StopRequest:
    """A signal to stop: raised at once, and remembered, so that a library that swallows the
    exception (PsychoPy opening its window catches broadly) cannot keep the session going."""

    def __init__(self):
        self.reason: str | None = None

    def __call__(self, number, frame):
        self.reason = signal.Signals(number).name
        raise SessionAborted(self.reason)

    def check(self) -> None:
        if self.reason is not None:
            raise SessionAborted(self.reason)


def run_session(
    protocol: Protocol,
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
    accept_mismatch: tuple[str, ...] = (),
    allow_unmeasured_refresh: bool = False,
    pilot: bool = False,
) -> dict:
    """Run (or resume) one session; return its sidecar.

    Parameters
    ----------
    protocol, participant, session, out
        The study, who, which session, and the folder for its files.
    frontend
        The device: :class:`glarelab.frontend.session.PsychoPyFrontend` or
        :class:`SimulatedFrontend`.
    stimuli, calibration, allow_uncalibrated
        The stimulus set folder and the display calibration (see the module notes).
    resume
        Continue the session's files instead of starting new ones.
    counterbalance
        Spencer's block order (default: from the participant's number).
    participant_info
        Age, sex, vision correction (a resume keeps the stored ones).
    simulated
        A simulated observer: it looks at the stimulus set's images as the set's calibration
        shows them; no calibration or display checks.
    accept_mismatch
        Display checks whose failure is accepted (recorded): ``resolution``, ``refresh``,
        ``bit-depth``, ``calibration``.
    allow_unmeasured_refresh
        Run although the refresh rate could not be measured (recorded).
    pilot
        A pilot run, as PsychoPy's piloting mode: the display's resolution, refresh and bit
        depth checks and an unverified calibration are accepted (recorded), and every file
        says it is a pilot (``_pilot`` in the names, ``pilot`` in the sidecar, the log's and
        frame file's run lines). A real session refuses an unverified calibration unless
        ``allow_uncalibrated``.

    Raises
    ------
    ValueError
        Before any trial and before any file is written: see the module notes.
    """
    started = _now()
    check_session_id(participant, session)
    check_counterbalance(protocol, counterbalance)
    # a participant's session is held before anything is checked (verifying a set takes
    # seconds), whatever its folder; simulated ones, run by the thousand, hold their folder
    lock = None
    if not simulated:
        lock = SessionLock(out, participant, protocol.study, session, across_folders=True)
        lock.acquire()
    try:
        return _run_session_locked(
            protocol,
            participant,
            lock=lock,
            started=started,
            out=out,
            frontend=frontend,
            session=session,
            stimuli=stimuli,
            calibration=calibration,
            allow_uncalibrated=allow_uncalibrated,
            resume=resume,
            counterbalance=counterbalance,
            participant_info=participant_info,
            simulated=simulated,
            accept_mismatch=accept_mismatch,
            allow_unmeasured_refresh=allow_unmeasured_refresh,
            pilot=pilot,
        )
    finally:
        if lock is not None:
            lock.release()


def _run_session_locked(
    protocol: Protocol,
    participant: str,
    *,
    lock,
    started: datetime,
    out: Path,
    frontend,
    session: int,
    stimuli: Path | None,
    calibration: Calibration | None,
    allow_uncalibrated: bool,
    resume: bool,
    counterbalance: int | None,
    participant_info: dict | None,
    simulated: bool,
    accept_mismatch: tuple[str, ...],
    allow_unmeasured_refresh: bool,
    pilot: bool,
) -> dict:
    """:func:`run_session` once the session is held (``lock``, None: its folder's lock)."""
    accept = set(accept_mismatch) | ({"refresh-unmeasured"} if allow_unmeasured_refresh else set())
    if pilot:
        accept |= {"resolution", "refresh", "bit-depth", "refresh-unmeasured"}
    manifest_sha = _check_stimuli(protocol, stimuli)
    if simulated:
        calibration_record = {
            "calibrated": False,
            "status": "simulated",
            "readings_sha256": None,
            "curve_sha256": None,
        }
        checks = []
    elif not shows_images(protocol) and not (
        calibration is not None and (protocol.data.get("scene") or {}).get("live")
    ):  # a questionnaire shows no luminances (a live scene encodes through a given calibration)
        calibration_record = {
            "calibrated": False,
            "status": "not needed",
            "readings_sha256": None,
            "curve_sha256": None,
        }
        checks = []
    else:
        calibration_record = usable_calibration(calibration, allow_uncalibrated=allow_uncalibrated)
        checks = enforce(check_calibration(protocol, calibration), accept=accept)
        if calibration_record["status"] == "unverified":  # as the README promises
            if not (pilot or allow_uncalibrated):
                raise ValueError(
                    "the display calibration is unverified (it has no verification pass): "
                    "measure the display with glarelab calibrate measure, run a pilot "
                    "(--pilot), or accept it explicitly (--allow-uncalibrated, recorded)"
                )
            calibration_record["accepted_unverified_by"] = (
                "--pilot" if pilot else "--allow-uncalibrated"
            )
    stop = _StopRequest()
    started_run = False
    with _signals(stop):  # Ctrl-C or kill before the first trial: stopped, nothing written
        files = SessionFiles(
            protocol,
            participant,
            session,
            Path(out),
            resume=resume,
            started=started,
            pilot=pilot,
            lock=lock,
        )
        try:
            info = {key: (participant_info or {}).get(key) for key in INFO_KEYS}
            info |= {k: v for k, v in (participant_info or {}).items() if k not in INFO_KEYS}
            sidecar = files.read_sidecar() if resume else {}
            if resume:
                info, counterbalance = _check_resume(
                    sidecar,
                    files,
                    protocol,
                    manifest_sha,
                    calibration_record,
                    info,
                    counterbalance,
                )
            facts = frontend.open()
            frontend.should_stop = stop.check
            _check_set_in_use(frontend, stimuli, manifest_sha)
            try:
                stop.check()
                if facts is not None:
                    checks += enforce(check_screen(protocol, facts), accept=accept)
                rate = timing_rate_hz(protocol, facts, checks)
                engine = make_engine(
                    protocol,
                    participant,
                    session=session,
                    counterbalance=counterbalance,
                    refresh_hz=rate,
                )
                if resume:  # a session that does not replay is refused before anything is written
                    try:
                        engine.replay(files.rows)
                    except ValueError as error:
                        raise SessionError(f"{files.csv_path.name}: {error}") from None
                presentation = _check_presentation(
                    frontend, protocol, participant, session, counterbalance, rate
                )
                files.open()
                sidecar = _start_run(
                    sidecar,
                    files,
                    engine,
                    protocol,
                    info=info,
                    started=started,
                    checks=checks,
                    facts=facts,
                    rate=rate,
                    frontend=frontend,
                    manifest_sha=manifest_sha,
                    calibration_record=calibration_record,
                    simulated=simulated,
                    pilot=pilot,
                )
                sidecar["runs"][-1]["presentation_check"] = presentation
                try:
                    files.write_sidecar(sidecar)
                except OSError as error:
                    files.discard()
                    raise SessionError(
                        f"could not write {files.sidecar_path} ({error.strerror or error}); the "
                        "session did not start"
                    ) from None
                try:
                    frontend.start(
                        run=len(sidecar["runs"]),
                        started=_iso(started),
                        refresh_hz=rate,
                        pace=facts is not None and not _refresh_verified(checks),
                        frames_path=files.frames_path if facts is not None else None,
                        log_path=files.log_path if facts is not None else None,
                    )
                    pupil = getattr(frontend, "pupil_calibration", None)
                    if pupil is not None:  # Luidolt's pupil range, measured as the run started
                        sidecar["runs"][-1]["pupil_calibration"] = pupil.as_dict()
                        files.write_sidecar(sidecar)
                except BaseException as error:  # stopped or failed while starting
                    if stop.reason is not None and not isinstance(error, SessionAborted):
                        # a signal's stop that the window's cleanup turned into its own error
                        # (a flip cut short inside a GL call fails the next one)
                        error = SessionAborted(stop.reason)
                    if files.created and not getattr(frontend, "collecting", False):
                        raise error  # nothing collected: the new session's files are discarded
                    started_run = True  # what the tracker recorded, or a resumed run, is kept
                    _finish_run(sidecar, files, None, None, "aborted", _ended_by(error, files))
                    raise error
                started_run = True  # from here the files are the run's record, kept
                if hasattr(frontend, "display_lost"):  # a window whose display may go away

                    def display_lost() -> None:
                        files.release_reserve()  # the room set aside for the sidecar's end
                        reason = "display lost: the X server ended or the session was closed"
                        _finish_run(sidecar, files, None, None, "aborted", reason)
                        files.close()  # the lock given back

                    frontend.display_lost = display_lost
                try:
                    _run_trials(engine, frontend, files, sidecar, protocol, rate, resume, stop)
                finally:  # the run's end is written: a display lost later rewrites nothing
                    if hasattr(frontend, "display_lost"):
                        frontend.display_lost = None
            finally:
                frontend.close()
        except BaseException:
            if files.created and not files.rows and not started_run:  # stopped before its start
                files.discard()
            raise
        finally:
            files.close()
    return sidecar


def _check_presentation(frontend, protocol: Protocol, participant, session, counterbalance, rate):
    """The first trial's images drawn in the session's window and read back (a front-end that
    can, with a stimulus set): what the sidecar records; a warning if the screen does not show
    their codes."""
    check = getattr(frontend, "check_presentation", None)
    if check is None:
        return None
    engine = make_engine(
        protocol, participant, session=session, counterbalance=counterbalance, refresh_hz=rate
    )
    result = check(first_screen(engine))
    if result is not None and not result["exact"]:
        shown = ", ".join(
            f"{image['role']} {100 * image['exact_fraction']:.2f} %" for image in result["images"]
        )
        print(
            f"[glarelab] warning: the screen does not show the stimulus set's codes (pixels "
            f"exact: {shown}); run glarelab check-display {protocol.study} --stimuli SET on "
            "this display",
            file=sys.stderr,
            flush=True,
        )
    return result


def _refresh_verified(checks: list[dict]) -> bool:
    return any(c["name"] == "refresh" and c["passed"] for c in checks)


def _start_run(
    sidecar: dict,
    files: SessionFiles,
    engine,
    protocol: Protocol,
    *,
    info: dict,
    started: datetime,
    checks: list[dict],
    facts,
    rate: float,
    frontend,
    manifest_sha: str | None,
    calibration_record: dict,
    simulated: bool,
    pilot: bool = False,
) -> dict:
    """The sidecar of a run that starts now (earlier runs kept; a killed one marked)."""
    runs = list(sidecar.get("runs", []))
    if runs and runs[-1].get("status") == "running":  # killed: it never wrote its end
        runs[-1] |= _interrupted(runs[-1], files)
    runs.append(
        {
            "started": _iso(started),
            "ended": None,
            "status": "running",
            "pilot": pilot,
            "trials_before": len(files.rows),
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "keyboard": getattr(frontend, "keyboard", None),
            "clock_epoch_s": frontend.clock_epoch_s(),
            "display": None
            if facts is None
            else {
                "resolution_px": list(facts.resolution_px),
                "refresh_hz_measured": facts.refresh_hz,
                "bits_per_channel": facts.bits_per_channel,
                "timing_refresh_hz": rate,
                "frame_pacing": "vertical sync" if _refresh_verified(checks) else "clock",
            },
            "checks": checks,
            "accepted_mismatches": [c["name"] for c in checks if c["accepted"]],
            "log": files.log_path.name if facts is not None else None,
            "frame_intervals": files.frames_path.name if facts is not None else None,
        }
    )
    return sidecar | {
        "data_format": DATA_FORMAT,
        "study": protocol.study,
        "participant": engine.participant,
        "session": engine.session,
        "participant_info": info,
        "protocol_sha256": protocol.sha256,
        "protocol_source": protocol.source,
        "stimulus_set_manifest_sha256": manifest_sha,
        "calibration": calibration_record,
        "packages": package_versions(PACKAGES),
        "refresh_hz": rate,
        "bit_depth": None if facts is None else facts.bits_per_channel,
        "simulated": simulated,
        "pilot": pilot,
        "images_encoded_with": getattr(frontend, "calibration_used", None),
        "counterbalance": getattr(engine, "counterbalance", None),
        "trial_order": getattr(engine, "order", None),
        "status": "running",
        "started": sidecar.get("started", _iso(started)),
        "ended": None,
        "runs": runs,
        "resumed": len(runs) - 1,
        "trials": len(files.rows),
        "row_sha256": files.row_digests(),
    }


def _interrupted(run: dict, files: SessionFiles) -> dict:
    """What is known of a run that ended without writing its end (killed, crashed, power
    lost): its trials, counted from the CSV, and the last time one of its files was written;
    when it ended is not known."""
    started = datetime.fromisoformat(run["started"]) if run.get("started") else None
    writes = []
    for path in (files.csv_path, files.log_path, files.frames_path):
        with contextlib.suppress(OSError):
            moment = datetime.fromtimestamp(path.stat().st_mtime, UTC).astimezone()
            if started is None or moment >= started:  # a write of this run, not an earlier one
                writes.append(moment)
    return {
        "status": "interrupted",
        "ended": None,
        "ended_by": "unknown: the process ended without recording its end (killed or crashed)",
        "last_write": _iso(max(writes)) if writes else None,
        "trials_after": len(files.rows),
    }


def _run_trials(engine, frontend, files, sidecar, protocol: Protocol, rate, resume, stop) -> None:
    trials = protocol.data.get("trials", {})

    def record(row: dict) -> None:
        """A trial's row, then its digest in the sidecar: a run killed later (power lost)
        leaves every row it wrote vouched for, so a row changed before --resume is named."""
        files.write_row(row)
        sidecar["row_sha256"] = files.row_digests()
        files.write_sidecar(sidecar)

    loop = SessionLoop(
        frontend,
        record,
        refresh_hz=rate,
        timing_tolerance_ms=trials.get("timing_tolerance_ms", 10.0),
        break_every=trials.get("break_every", 0),
        log=frontend.log,
    )
    status, reason = "aborted", None
    try:
        with _signals(stop):
            try:
                stop.check()
                loop.run(engine, resumed_after=len(files.rows) if resume else 0)
                files.check_in_place()  # a CSV removed after its last trial is not completed
                status = "completed"
            except SessionAborted as abort:
                reason = abort.args[0] if abort.args else "escape"
            except OSError as error:  # the disk is full or gone: stop, keep what is written
                where = f" {error.filename}" if error.filename else ""
                reason = f"could not write{where}: {error.strerror or error}"
                files.release_reserve()  # the room set aside for the sidecar's and log's end
                with contextlib.suppress(Exception):
                    frontend.log(f"session stopped: {reason}")
                _finish_run(sidecar, files, engine, loop, status, reason)
                raise WriteFault(
                    f"the session stopped after {len(files.rows)} trials: {reason} "
                    f"({files.csv_path}); every trial before it is on disk, and "
                    f"{files.sidecar_path.name} says why it ended"
                ) from None
            except BaseException as error:
                reason = f"error: {type(error).__name__}: {error}"
                raise
    finally:
        if reason is None or not reason.startswith("could not write"):
            _finish_run(sidecar, files, engine, loop, status, reason)
    if status == "completed":
        with contextlib.suppress(SessionAborted), _signals(stop):
            loop.pause({"kind": "end", "text": END_TEXT, "keys": {"space": "close"}})
        if stop.reason is not None:  # a signal on the end screen: the session is whole, and
            raise SessionAborted(stop.reason)  # the command stops as Ctrl-C asks (exit 3)


def _ended_by(error: BaseException, files: SessionFiles) -> str:
    """Why a run ended before its first trial, as its sidecar says (the room set aside for
    the sidecar's end is given back when the disk failed)."""
    if isinstance(error, SessionAborted):
        return error.args[0] if error.args else "escape"
    if isinstance(error, OSError):
        files.release_reserve()
        where = f" {error.filename}" if error.filename else ""
        return f"could not write{where}: {error.strerror or error}"
    return f"error: {type(error).__name__}: {error}"


def _finish_run(sidecar, files, engine, loop, status, reason) -> None:
    """Write the run's end into the sidecar whole; a Ctrl-C meanwhile is delivered after it
    (``loop`` None: the run ended before its first trial)."""
    with _signals_deferred():
        ended = _now()
        sidecar["runs"][-1] |= {
            "ended": _iso(ended),
            "status": status,
            "trials_after": len(files.rows),
            "ignored_key_presses": 0 if loop is None else loop.total_ignored,
            "ended_by": reason,
        }
        sidecar |= {
            "status": status,
            "ended": _iso(ended),
            "trials": len(files.rows),
            "row_sha256": files.row_digests(),
        }
        try:
            files.write_sidecar(sidecar)
        except OSError as error:  # the CSV holds the trials; say what the sidecar lacks
            print(
                f"[glarelab] could not update {files.sidecar_path} ({error.strerror or error}): "
                f"it still says 'running'; the session ended {status} after {len(files.rows)} "
                "trials",
                file=sys.stderr,
            )
