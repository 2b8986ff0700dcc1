"""One simulated study: a protocol's simulated participants through the session loop, then the
protocol's analysis, at each sample size.

A replication runs the largest sample size's participants through
:func:`glarelab.experiments.session.run_session` (a
:class:`glarelab.experiments.session.SimulatedFrontend` driven by
:func:`glarelab.experiments.session.make_observer`, as ``glarelab run --simulate`` does) into a
scratch folder, then the paradigm's analysis (:mod:`glarelab.analysis.paradigms`, its tests alone)
on the first ``n`` participants for each sample size ``n``. The sample sizes of one replication
share their participants (common random numbers): each sample size's power is estimated from
independent replications, and the differences between sample sizes are estimated more precisely
than from separate studies.

Participant ids, and with them every random draw (the observer's gain, its noise on every
trial, the trial order; :func:`glarelab.experiments.engine.participant_rng`), follow from the power
seed, the replication and the participant's number alone, so a replication gives the same
result on any worker, in any order, in any run.
"""

from __future__ import annotations

import glob
import os
import shutil
import socket
import tempfile
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from glarelab.analysis.load import load_sessions
from glarelab.analysis.paradigms import paradigm_analysis
from glarelab.experiments.data import session_files
from glarelab.experiments.session import (
    SimulatedFrontend,
    make_observer,
    run_session,
)
from glarelab.observers.looking import ObservedSet
from glarelab.planning.effects import effects
from glarelab.stimuli.stimulus_set import (
    StimulusSet,
    cached_stimulus_set,
    shows_images,
    verify_stimulus_set,
)

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["PowerJob", "default_scratch", "participant_id", "simulate_replication"]


def participant_id(replication: int, number: int) -> str:
    """The id of participant ``number`` (from 1) of a replication (from 0).

    Parameters
    ----------
    replication
        The replication, >= 0.
    number
        The participant within it, >= 1.

    Returns
    -------
    str
        ``repRRRRRR-pNNN``.

    Raises
    ------
    ValueError
        For a negative replication or a number below 1.

    Examples
    --------
    >>> participant_id(12, 3)
    'rep000012-p003'
    """
    if replication < 0 or number < 1:
        raise ValueError(
            f"replication must be >= 0 and number >= 1; got {replication!r}, {number!r}"
        )
    return f"rep{replication:06d}-p{number:03d}"


SCRATCH_PREFIX = "glarelab-power-"  # then host, PID namespace and process: see _own_prefix


def _own_prefix() -> str:
    """The scratch folders' prefix of this host's processes in this PID namespace: only they
    can be told gone by their process id (a run on another host, or in a container sharing
    /dev/shm, has ids of its own)."""
    try:
        namespace = str(os.stat("/proc/self/ns/pid").st_ino)
    except OSError:
        namespace = "0"
    host = "".join(c if c.isalnum() else "_" for c in socket.gethostname())
    return f"{SCRATCH_PREFIX}{host}.{namespace}-"


def _remove_stale(scratch: Path) -> None:
    """Remove the scratch folders of processes of this host and PID namespace that are gone
    (a power run killed by SIGKILL cannot remove its own; in /dev/shm they would hold memory
    until a reboot)."""
    own = _own_prefix()
    try:
        entries = list(scratch.glob(f"{glob.escape(own)}*-*"))
    except OSError:
        return
    for entry in entries:
        pid = entry.name[len(own) :].split("-", 1)[0]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:  # no such process: its folder is left over
            shutil.rmtree(entry, ignore_errors=True)
        except (PermissionError, OverflowError, OSError):
            continue  # another user's live process, or no pid at all: not ours to remove


def default_scratch() -> Path:
    """Where simulated sessions are written and deleted: ``/dev/shm`` (memory) where there is
    one to write to, else the system's temporary folder. Each trial's row is fsync'ed, as in
    a lab session; in memory that costs nothing."""
    shm = Path("/dev/shm")
    if shm.is_dir() and os.access(shm, os.W_OK):
        return shm
    return Path(tempfile.gettempdir())


def _simulate_sessions(
    protocol: Protocol,
    participants: Sequence[str],
    *,
    seed: int,
    out: Path,
    stimuli: Path | None,
    looks_at,
) -> list[Path]:
    """Run each participant's first session with a simulated observer into ``out``, as
    ``glarelab run --simulate`` does; return their CSVs, in the participants' order.

    ``stimuli`` is the set's folder the sessions show (None for a paradigm that shows no
    images); ``looks_at`` what the observers look at: the folder, or a
    :class:`glarelab.observers.looking.ObservedSet` they share.
    """
    csvs = []
    for participant in participants:
        observer = make_observer(protocol, participant, seed=seed, stimuli=looks_at)
        sidecar = run_session(
            protocol,
            participant,
            out=out,
            frontend=SimulatedFrontend(observer),
            stimuli=stimuli,
            simulated=True,
            participant_info={"simulated_observer_seed": seed},
        )
        if sidecar["status"] != "completed":
            # a simulated session ends early only when it is told to stop (Ctrl-C, SIGTERM):
            # the whole study stops, rather than count this replication as a failed one
            raise KeyboardInterrupt(sidecar["runs"][-1].get("ended_by") or sidecar["status"])
        files = session_files(out, participant, protocol.study, 1)
        csvs += [f for f in files if f.suffix == ".csv"]
    return csvs


def simulate_replication(
    protocol: Protocol,
    replication: int,
    *,
    participants: tuple[int, ...],
    seed: int,
    stimuli: Path | None,
    displayed: ObservedSet | None = None,
    scratch: Path | None = None,
) -> dict:
    """Simulate one study at every sample size; return its effects.

    Parameters
    ----------
    protocol
        The study (:func:`glarelab.protocols.load_protocol`).
    replication
        Which replication (>= 0): with ``seed`` it fixes every participant.
    participants
        The sample sizes (each >= 2).
    seed
        The simulated observers' seed.
    stimuli
        The stimulus set's folder (None for a paradigm that shows no images).
    displayed
        The set as displayed, shared by the observers (and their percepts); default: made here.
    scratch
        Folder for the sessions' files (deleted afterwards); default :func:`default_scratch`.

    Returns
    -------
    dict
        ``replication``; ``results``, one row per sample size and effect
        (:func:`glarelab.planning.effects.effects` plus ``n``); ``failures``, the sample sizes
        whose analysis refused the data, with why.
    """
    largest = max(participants)
    if displayed is None and stimuli is not None:
        displayed = ObservedSet(StimulusSet(stimuli))
    where = Path(scratch or default_scratch())
    _remove_stale(where)
    folder = Path(tempfile.mkdtemp(prefix=f"{_own_prefix()}{os.getpid()}-", dir=where))
    try:
        ids = [participant_id(replication, number) for number in range(1, largest + 1)]
        csvs = _simulate_sessions(
            protocol, ids, seed=seed, out=folder, stimuli=stimuli, looks_at=displayed
        )
        results, failures = [], []
        tests = paradigm_analysis(protocol).tests
        for n in sorted(participants):
            try:
                dataset = load_sessions(protocol, csvs[:n])
                tables = tests(dataset, protocol)
            except ValueError as error:  # the analysis refuses these data (named in error)
                failures.append({"n": n, "error": str(error)})
                continue
            results += [{"n": n, **row} for row in effects(protocol, tables, n)]
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return {"replication": replication, "results": results, "failures": failures}


class PowerJob:
    """The replications of a power analysis as tasks (see :mod:`glarelab.planning.execute`).

    Each worker thread looks at its own :class:`glarelab.observers.looking.ObservedSet` of the
    stimulus set, made once (:meth:`setup`) and kept for every replication it runs. A worker
    that cannot read ``stimuli`` (a cluster without a shared file system) builds the protocol's
    set into its own cache (:func:`glarelab.stimuli.stimulus_set.cached_stimulus_set`).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study.
    participants
        The sample sizes, each >= 2.
    seed
        The simulated observers' seed.
    stimuli
        The protocol's stimulus set; None only for a protocol that shows no images.
    scratch
        Folder for the simulated sessions' files; default None:
        :func:`default_scratch`.
    task_delay_s
        Seconds each replication waits before it runs, default 0 (for tests that stop a run
        part way).

    Raises
    ------
    ValueError
        For a sample size below 2, or no stimulus set for a protocol that shows images.
    """

    kind = "power"

    def __init__(
        self,
        protocol: Protocol,
        *,
        participants: tuple[int, ...],
        seed: int,
        stimuli: Path | None,
        scratch: Path | None = None,
        task_delay_s: float = 0.0,
    ):
        if not participants or min(participants) < 2:
            raise ValueError(f"participants must be sample sizes >= 2; got {participants!r}")
        if shows_images(protocol) and stimuli is None:
            raise ValueError(f"the {protocol.study} power analysis needs its stimulus set")
        self.protocol = protocol
        self.participants = tuple(sorted(set(participants)))
        self.seed = seed
        self.stimuli = stimuli
        self.scratch = scratch
        self.task_delay_s = task_delay_s
        self._local = threading.local()

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state.pop("_local")
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._local = threading.local()

    def setup(self) -> tuple[Path | None, ObservedSet | None]:
        """The stimulus set this worker reads, and the set as displayed."""
        if self.stimuli is None:
            return None, None
        folder = self.stimuli
        if verify_stimulus_set(folder):  # not readable here, or changed: this worker's own
            folder = cached_stimulus_set(self.protocol, progress=None)
        return folder, ObservedSet(StimulusSet(folder))

    def run(self, replication: int) -> dict:
        """Simulate and analyse one replication.

        Parameters
        ----------
        replication
            The replication's number, >= 0 (:func:`simulate_replication`).

        Returns
        -------
        dict
            As :func:`simulate_replication` returns it.
        """
        if not hasattr(self._local, "state"):
            self._local.state = self.setup()
        folder, displayed = self._local.state
        if self.task_delay_s:
            import time

            time.sleep(self.task_delay_s)
        return simulate_replication(
            self.protocol,
            replication,
            participants=self.participants,
            seed=self.seed,
            stimuli=folder,
            displayed=displayed,
            scratch=self.scratch,
        )
