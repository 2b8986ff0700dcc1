"""The ``glarelab`` commands of sessions: run."""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import sys
from pathlib import Path

from glarelab.display.calibration import Calibration
from glarelab.files.folders import record_written
from glarelab.files.inputs import loads_json, read_input_text
from glarelab.protocols import load_protocol

from .common import (
    PROTOCOL_HELP,
    add_monitor_options,
    apply_monitor,
    claim_output,
    count,
    inside_whole_output,
    number,
    output_file,
)
from .common import log as _log

VISION = ("none", "glasses", "lenses", "other")


def _age(text: str) -> int:
    """An age in whole years, 0-120."""
    try:
        age = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"age must be whole years; got {text!r}") from None
    if not 0 <= age <= 120:
        raise argparse.ArgumentTypeError(f"age must be 0-120 years; got {age}")
    return age


def _participant(text: str) -> str:
    """A participant id: file-name safe, as the session files are named by it."""
    from glarelab.experiments.data import check_session_id

    try:
        check_session_id(text, 1)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error).replace("participant must", "must")) from None
    return text


def _detail(text: str) -> str | None:
    """A participant detail: trimmed text, or none when empty."""
    return text.strip() or None


def _protocol(study: str | None, path: Path | None):
    """The session's protocol: STUDY, or ``--protocol FILE`` instead; both only when they name
    the same study."""
    if study is None and path is None:
        raise ValueError(
            "give the study (STUDY: a shipped study's name or a TOML file) or --protocol FILE"
        )
    if path is None:
        return load_protocol(study)
    protocol = load_protocol(path)
    if study is not None:
        named = load_protocol(study).study if Path(study).suffix else study
        if named != protocol.study:
            raise ValueError(
                f"STUDY {study!r} and --protocol {path} (the protocol of study "
                f"{protocol.study!r}) name two studies; give one of them"
            )
    return protocol


SIMULATED_PARTICIPANTS = 10  # Yoshida 2008's study had ten participants (§5: F(1, 9))
WRITE_FAULT = 4  # the exit status of a session stopped because its files could not be written


def _run(args: argparse.Namespace) -> int:
    """``glarelab run``; a session whose files stop being writable (a full disk) ends with
    :data:`WRITE_FAULT`: its trials so far are on disk and its sidecar says why it ended."""
    from glarelab.experiments.data import WriteFault

    try:
        return _run_session(args)
    except WriteFault as fault:
        print(f"glarelab run: {fault}", file=sys.stderr)
        return WRITE_FAULT


# the options of a session on a screen, which a simulated one would ignore, and the reverse
SCREEN_ONLY = (
    "eyetracker",
    "pupil_calibration_s",
    "screenshot",
    "scripted_keys",
    "age",
    "sex",
    "vision",
    "calibration",
    "fullscreen",
    "accept_mismatch",
    "allow_uncalibrated",
    "allow_unmeasured_refresh",
)
SIMULATED_ONLY = ("participants", "seed")


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _batch_resume(out: Path, participant: str, study: str, session: int) -> bool | None:
    """How ``--resume`` goes on with one simulated participant of a batch: None for a
    session that completed (kept as it is), True for one that did not (resumed), False for
    one that never started (run from its start)."""
    from glarelab.experiments.data import session_files

    files = session_files(out, participant, study, session)
    if not any(p.suffix == ".csv" for p in files):
        sidecars = [p for p in files if p.suffix == ".json"]
        if sidecars:  # a session ran: its trials are gone, not never written
            raise ValueError(
                f"{sidecars[0]} has no CSV beside it (deleted or moved?): {participant}'s "
                f"session {session} ran, and without its trials it can be neither kept nor "
                "resumed; put the CSV back, or give another --out"
            )
        return False
    for sidecar in (p for p in files if p.suffix == ".json"):
        with contextlib.suppress(OSError, ValueError):
            data = loads_json(sidecar.read_text(encoding="utf-8"))
            if isinstance(data, dict) and data.get("status") == "completed":
                return None
    return True  # resumed, or refused by the session's own checks, naming why


def _check_batch_seed(
    out: Path, ids: list[str], study: str, session: int, seed: int, stimuli
) -> None:
    """Refuse a batch resumed with another seed than its sessions were simulated with (their
    sidecars' ``simulated_observer_seed``), or on another stimulus set than they ran on (their
    ``stimulus_set_manifest_sha256``, a set rebuilt since): the batch would mix observers of
    two seeds, or sessions of two sets, which the analysis refuses."""
    from glarelab.experiments.data import session_files

    manifest = None
    if stimuli is not None:  # a folder that is no set is named by the session's own checks
        with contextlib.suppress(OSError):
            data = (Path(stimuli) / "manifest.json").read_bytes()
            manifest = hashlib.sha256(data).hexdigest()
    others: dict[int, list[str]] = {}
    sets: dict[str, list[str]] = {}
    for participant in ids:
        for sidecar in (p for p in session_files(out, participant, study, session)
                        if p.suffix == ".json"):  # fmt: skip
            with contextlib.suppress(OSError, ValueError, AttributeError):
                recorded = loads_json(sidecar.read_text(encoding="utf-8"))
                info = recorded.get("participant_info")
                used = (info or {}).get("simulated_observer_seed")
                if isinstance(used, int) and used != seed:
                    others.setdefault(used, []).append(participant)
                ran_on = recorded.get("stimulus_set_manifest_sha256")
                if manifest is not None and isinstance(ran_on, str) and ran_on != manifest:
                    sets.setdefault(ran_on, []).append(participant)
    if others:
        used, who = next(iter(others.items()))
        raise ValueError(
            f"--seed {seed}: {', '.join(who[:4])}{' …' if len(who) > 4 else ''} of this batch "
            f"in {out} were simulated with seed {used}; a batch goes on with the seed it began "
            f"with: give --seed {used}, or another --out for a batch of seed {seed}"
        )
    if sets:
        ran_on, who = next(iter(sets.items()))
        raise ValueError(
            f"the stimulus set {stimuli} (manifest sha256 {manifest[:12]}…): "
            f"{', '.join(who[:4])}{' …' if len(who) > 4 else ''} of this batch in {out} ran on "
            f"the set with manifest sha256 {ran_on[:12]}… (rebuilt since?); a batch goes on "
            "with the set it began with: give that set (--stimuli), or another --out for a "
            "batch on this one"
        )


def _check_run_options(args: argparse.Namespace, protocol) -> None:
    """Refuse every option the session would ignore, in one line."""
    from glarelab.experiments.session import check_counterbalance
    from glarelab.stimuli.stimulus_set import shows_images

    defaults = {a.dest: a.default for a in _parser_actions()}
    given = [n for n in (*SCREEN_ONLY, *SIMULATED_ONLY) if getattr(args, n) != defaults[n]]
    if args.simulate:
        ignored = [n for n in given if n in SCREEN_ONLY]
        if ignored:
            raise ValueError(
                f"{', '.join(map(_flag, ignored))} with --simulate: a simulated session has no "
                "screen, keyboard or participant details, so it would ignore them"
            )
    else:
        ignored = [n for n in given if n in SIMULATED_ONLY]
        if ignored:
            raise ValueError(
                f"{', '.join(map(_flag, ignored))}: options of simulated sessions "
                "(--simulate), which a session on the screen would ignore"
            )
    live = bool((protocol.data.get("scene") or {}).get("live"))
    if args.eyetracker is not None and not live:
        raise ValueError(
            f"--eyetracker {args.eyetracker}: the {protocol.study} protocol shows no live scene "
            "(a rating protocol's [scene] with live = true), so it would ignore the tracker"
        )
    if args.pupil_calibration_s is not None and args.eyetracker is None:
        raise ValueError(
            f"--pupil-calibration-s {args.pupil_calibration_s:g}: the pupil calibration runs "
            "with an eye tracker; give --eyetracker"
        )
    if live and not args.simulate and args.eyetracker is None:
        raise ValueError(
            f"the {protocol.study} protocol shows its scene live for the gaze: give --eyetracker "
            "mouse (the mouse as the gaze) or the ioHub configuration (.yaml) of a tracker"
        )
    if args.stimuli is not None and not shows_images(protocol):
        raise ValueError(
            f"--stimuli {args.stimuli}: the {protocol.study} protocol ({protocol.paradigm}) "
            "shows no images, so it would ignore a stimulus set"
        )
    check_counterbalance(protocol, args.counterbalance)
    if live and not args.simulate:  # its bank is made after the pupil calibration: refused now
        from glarelab.protocols import ProtocolError
        from glarelab.stimuli.kernels import check_kernels
        from glarelab.stimuli.paradigms import paradigm_stimuli

        refused = check_kernels(paradigm_stimuli(protocol).kernels(protocol))
        if refused:
            raise ProtocolError(protocol.source, refused)


def _parser_actions():
    import argparse as _argparse

    parser = _argparse.ArgumentParser(add_help=False)
    commands = parser.add_subparsers()
    add(commands)
    return commands.choices["run"]._actions


def _scripted_key_names(path: Path, names: list[str]) -> None:
    """Refuse a name that is no key (a typo would be an ignored press)."""
    from glarelab.frontend.keys import unknown_key_names

    unknown = unknown_key_names(names)
    if unknown:
        raise ValueError(
            f"--scripted-keys {path}: {', '.join(map(repr, unknown[:5]))} not a key name "
            "(PsychoPy's names: a-z, 0-9, space, return, escape, up, down, left, right, "
            "num_0-num_9, …)"
        )


def _check_out_can_be_made(out: Path) -> None:
    """Refuse an ``--out`` whose folder cannot be made, naming it (the folders made to find
    out are removed again: a refused session leaves nothing)."""
    missing = []
    while not out.exists() and not out.is_symlink() and out.parent != out:
        missing.append(out)
        out = out.parent
    made = []
    try:
        for folder in reversed(missing):
            folder.mkdir()
            made.append(folder)
    except OSError as error:
        raise ValueError(
            f"--out {missing[0]}: cannot create the folder ({error.strerror or error}); give "
            "a folder that can be made and written into (nothing was written)"
        ) from None
    finally:
        for folder in reversed(made):
            with contextlib.suppress(OSError):
                folder.rmdir()


def _run_session(args: argparse.Namespace) -> int:
    from glarelab.experiments.session import SimulatedFrontend, run_session

    protocol, monitor = apply_monitor(args, _protocol(args.study, args.protocol))
    args.title = protocol.study
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; session files go into a folder")
    whole = inside_whole_output(out / "session.csv")
    if whole is not None:
        raise ValueError(
            f"--out {out} is inside the {whole}, which glarelab replaces and checks as a "
            "whole: give a folder of its own for the session files (nothing was written)"
        )
    _check_run_options(args, protocol)
    _check_out_can_be_made(out)
    if args.simulate:
        from glarelab.experiments.session import check_completed_session, make_observer
        from glarelab.stimuli.stimulus_set import cached_stimulus_set, shows_images

        if args.participant is not None and args.participants is not None:
            raise ValueError(
                f"--participants {args.participants} with --participant {args.participant}: "
                "give one participant's id, or a number of simulated participants"
            )
        count = SIMULATED_PARTICIPANTS if args.participants is None else args.participants
        ids = (
            [args.participant]
            if args.participant is not None
            else [f"sim{index:02d}" for index in range(1, count + 1)]
        )
        stimuli = args.stimuli
        if stimuli is None and shows_images(protocol):
            _log(f"building (or reusing) the {protocol.study} stimulus set the observers look at")
            stimuli = cached_stimulus_set(protocol)
            _log(f"stimulus set: {stimuli}")
        batch = args.participant is None
        if args.resume and batch:  # a batch goes on with the seed and set it began with
            _check_batch_seed(out, ids, protocol.study, args.session, args.seed, stimuli)
        for number, participant in enumerate(ids, start=1):
            resume = args.resume
            if resume and batch:  # a batch goes on where it stopped
                resume = _batch_resume(out, participant, protocol.study, args.session)
                if resume is None:  # as it was written, or refused naming what changed
                    check_completed_session(
                        protocol, participant, out=out, session=args.session, pilot=args.pilot
                    )
                    _log(f"[{number}/{len(ids)}] {participant}: completed before, kept")
                    continue
            observer = make_observer(protocol, participant, seed=args.seed, stimuli=stimuli)
            frontend = SimulatedFrontend(observer, trial_delay_s=args.trial_delay_ms / 1000)
            sidecar = run_session(
                protocol,
                participant,
                out=out,
                frontend=frontend,
                session=args.session,
                stimuli=stimuli,
                resume=resume,
                counterbalance=args.counterbalance,
                simulated=True,
                participant_info={"simulated_observer_seed": args.seed},
                pilot=args.pilot,
            )
            done = f"{sidecar['trials']} trials, {sidecar['status']}"
            _log(f"[{number}/{len(ids)}] {participant}: {done}")
            if sidecar["status"] != "completed":  # stopped (Ctrl-C, a signal): the batch too
                left = len(ids) - number
                _log(f"stopped; {left} simulated participant(s) not run")
                print(out.resolve())
                return 3
        print(out.resolve())
        return 0
    if args.pilot and args.fullscreen:
        raise ValueError(
            "--pilot runs in a window (PsychoPy's piloting mode); --fullscreen is for sessions"
        )
    eyetracker = None
    if args.eyetracker is not None:
        from glarelab.frontend.eyetracker import tracker_config

        eyetracker = tracker_config(args.eyetracker)
    if args.participant is None:
        from glarelab.frontend.dialog import experiment_info

        experiment_info(args, check_age=_age, vision=VISION)
    from glarelab.frontend.session import PsychoPyFrontend

    calibration = Calibration.load(args.calibration) if args.calibration else None
    scripted = None
    if args.scripted_keys is not None:
        scripted = read_input_text(args.scripted_keys, what="--scripted-keys file").split()
        if not scripted:
            raise ValueError(f"--scripted-keys {args.scripted_keys}: the file names no keys")
        _scripted_key_names(args.scripted_keys, scripted)
    if args.screenshot is not None:
        output_file(
            args.screenshot,
            (".png",),
            "screenshot",
            inputs=[args.calibration, args.scripted_keys],
            forceable=False,  # run has no --force
        )
        claim_output(args.screenshot, "run --screenshot")
    frontend = PsychoPyFrontend(
        protocol,
        eyetracker=eyetracker,
        pupil_calibration_s=args.pupil_calibration_s,
        stimuli=args.stimuli,
        calibration=calibration,
        fullscreen=args.fullscreen,
        scripted_keys=scripted,
        screenshot=args.screenshot,
        pilot=args.pilot,
        monitor=monitor,
    )
    try:
        sidecar = run_session(
            protocol,
            args.participant,
            out=out,
            frontend=frontend,
            session=args.session,
            stimuli=args.stimuli,
            calibration=calibration,
            allow_uncalibrated=args.allow_uncalibrated,
            resume=args.resume,
            counterbalance=args.counterbalance,
            participant_info={"age": args.age, "sex": args.sex, "vision_correction": args.vision},
            accept_mismatch=tuple(args.accept_mismatch or ()),
            allow_unmeasured_refresh=args.allow_unmeasured_refresh,
            pilot=args.pilot,
        )
    finally:
        if args.screenshot is not None and Path(args.screenshot).is_file():
            record_written(Path(args.screenshot).parent, [Path(args.screenshot).name])
    run = sidecar["runs"][-1]
    _log(
        f"{args.participant}: {sidecar['trials']} trials, {sidecar['status']}"
        + (f" ({run['ended_by']})" if run.get("ended_by") else "")
        + f"; data in {out.resolve()}"
    )
    return 0 if sidecar["status"] == "completed" else 3


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
    run = commands.add_parser("run", help="run a study session (PsychoPy) or simulated sessions")
    run.add_argument(
        "study", nargs="?", default=None, help=f"the protocol: {PROTOCOL_HELP} (or --protocol)"
    )
    run.add_argument(
        "--participant",
        type=_participant,
        default=None,
        help="participant id (file-name safe); without it, a dialog asks for the details",
    )
    run.add_argument("--session", type=count(1), default=1, help="session number, from 1")
    run.add_argument(
        "--protocol", type=Path, default=None, help="a protocol TOML file (instead of STUDY)"
    )
    run.add_argument("--stimuli", type=Path, default=None, help="the stimulus set folder")
    run.add_argument("--calibration", type=Path, default=None, help="display calibration JSON")
    add_monitor_options(run)
    run.add_argument(
        "--allow-uncalibrated",
        action="store_true",
        help="run without a valid calibration, or on an unverified one (recorded)",
    )
    run.add_argument(
        "--accept-mismatch",
        nargs="+",
        choices=("resolution", "refresh", "bit-depth", "calibration"),
        metavar="CHECK",
        help="run although the display differs from the protocol in these checks (recorded): "
        "resolution, refresh, bit-depth, calibration",
    )
    run.add_argument(
        "--allow-unmeasured-refresh",
        action="store_true",
        help="run although the refresh rate could not be measured (recorded; flips are then "
        "paced by the clock at the protocol's rate)",
    )
    run.add_argument(
        "--pilot",
        action="store_true",
        help="a pilot run, as PsychoPy's piloting mode: in a window marked PILOT, accepting a "
        "display that is not the protocol's (resolution, refresh, bit depth, an unmeasured "
        "refresh) and an unverified calibration; every file says it is a pilot (recorded)",
    )
    run.add_argument(
        "--out",
        type=Path,
        default=Path("data"),
        help="folder for the session files (default data)",
    )
    run.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted session (a simulated batch: the sessions that did not "
        "complete, and those not yet run)",
    )
    run.add_argument(
        "--fullscreen", action="store_true", help="full screen on the lab display (else a window)"
    )
    run.add_argument(
        "--counterbalance", type=int, choices=(0, 1), default=None, help="Spencer block order"
    )
    run.add_argument("--age", type=_age, default=None, help="participant's age, years (0-120)")
    run.add_argument(
        "--sex", type=_detail, default=None, help="participant's sex (as the lab records it)"
    )
    run.add_argument(
        "--vision",
        choices=VISION,
        default=None,
        help=f"vision correction: {', '.join(VISION)}",
    )
    run.add_argument(
        "--scripted-keys",
        type=Path,
        default=None,
        help="dry run: a text file of PsychoPy key names separated by spaces or lines, one per "
        "press (e.g. 'space up up return y n y'); Escape when they run out",
    )
    run.add_argument(
        "--eyetracker",
        default=None,
        metavar="TRACKER",
        help="the eye tracker of a live scene (scene.live): 'mouse' (ioHub's MouseGaze, the "
        "mouse as the gaze; both buttons held: a blink), or an ioHub eye tracker's "
        "configuration file (.yaml; docs/night-vision.md)",
    )
    run.add_argument(
        "--pupil-calibration-s",
        type=number(0, above=True),
        default=None,
        metavar="S",
        help="with --eyetracker: seconds of each screen (white, black) of Luidolt's pupil range "
        "calibration, run as the tracker starts (default 5, his protocol's; MouseGaze's pupil "
        "is simulated)",
    )
    run.add_argument("--screenshot", type=Path, default=None, help="save the first trial's screen")
    run.add_argument("--simulate", action="store_true", help="simulated observers, no screen")
    run.add_argument(
        "--participants",
        type=count(1, 999),
        default=None,
        help="simulated participants sim01… (1-999; default 10); not with --participant",
    )
    run.add_argument("--seed", type=count(0), default=0, help="seed of the simulated observers")
    run.add_argument("--trial-delay-ms", type=number(0), default=0.0, help=argparse.SUPPRESS)
    run.set_defaults(run=_run)
