"""Matching by adjustment (Yoshida et al. 2008, §4): the engine and the simulated observer.

After the instructions and a training block, each reference (every level of every glare
method) is shown once, in an order randomised per participant (seeded, recorded). A trial shows
the reference and glare-free targets beside it. With ``settings = "bounds"`` (Yoshida) there
are two targets, left and right of the reference, starting at ``target_start_cd_m2``: the
participant selects one (``left``/``right``; a bar under it marks it), adjusts its disk
luminance (``up``/``down`` coarse, ``pageup``/``pagedown`` fine, one step a press: a key held
down is one press, as Psychtoolbox reports key-downs, not the system's key repeat; the
display's range bounds it)
and confirms with ``return`` when the left disk looks slightly but visibly darker and the right
slightly but visibly brighter than the reference; the match is their mean. With ``"single"``
one target, right of the reference, is set to look as bright. The protocol's yes/no questions
follow (``y`` / ``n``), asked with the trial's images as set: the paper's questions are about
them ("Does the reference image glow?", "Are the sizes of reference and target disks the
same?", Table 1; "a questionnaire followed each trial", §4), so they stay on the screen, the
selection bar gone. The row holds the settings, the match, the answers, the number of
adjustments and the time from the reference's onset to the confirming Enter.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from glarelab.experiments.engine import Engine, LookingObserver, participant_rng
from glarelab.protocols.matching import reference_name
from glarelab.stimuli.matching import target_terms

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["MatchingEngine", "MatchingObserver"]

STEP_KEYS = {"up": "coarse", "down": "coarse", "pageup": "fine", "pagedown": "fine"}
QUESTION_KEYS = {"y": "yes", "n": "no"}
LABELS = {"left": "slightly darker", "right": "slightly brighter"}


class MatchingEngine(Engine):
    """The engine of a matching protocol (no PsychoPy).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.
    participant
        The participant's id (it seeds the participant's orders).
    session
        The session's number, from 1; default 1.
    counterbalance
        Not used: the references come in the protocol's order or one randomised per
        participant (``trials.order``). Default None.
    refresh_hz
        Not used: nothing is timed. Default 60, Hz.
    """

    def __init__(
        self,
        protocol: Protocol,
        participant: str,
        *,
        session: int = 1,
        counterbalance: int | None = None,
        refresh_hz: float = 60.0,
    ):
        self.protocol = protocol
        self.study = protocol.study
        self.participant = participant
        self.session = session
        g, t = protocol["glare"], protocol["trials"]
        display = protocol["display"]
        self.low, self.high = display["black_cd_m2"], display["max_cd_m2"]
        self.coarse, self.fine = t["coarse_step_cd_m2"], t["fine_step_cd_m2"]
        self.bounds = t["settings"] == "bounds"
        self.sides = ("left", "right") if self.bounds else ("right",)
        self.starts = dict(
            zip(self.sides, protocol["stimulus"]["target_start_cd_m2"], strict=True)
        )
        self.questions = protocol["questionnaire"]["questions"]
        references = [
            {
                "method": m["name"],
                "level": label,
                "level_index": i + 1,
                "l_disk_cd_m2": level,
            }
            for m in g["methods"]
            for i, (label, level) in enumerate(zip(m["labels"], m["levels_cd_m2"], strict=True))
        ]
        rng = participant_rng(protocol.seed, participant, f"{protocol.study} order")
        training = [references[int(i)] for i in rng.choice(len(references), t["training_trials"])]
        main = (
            references
            if t["order"] == "fixed"
            else [references[int(i)] for i in rng.permutation(len(references))]
        )
        self.trials = [dict(r, block="training") for r in training] + [
            dict(r, block="main") for r in main
        ]
        self.index = 0
        self.phase = "instructions"
        self._new_trial()

    @classmethod
    def ordered(cls, protocol: Protocol) -> str:
        """The references' order: the protocol's, or randomised per participant.

        Parameters
        ----------
        protocol : glarelab.protocols.Protocol
            The study's protocol (its ``trials.order``).

        Returns
        -------
        str
            The clause :func:`glarelab.experiments.session.check_counterbalance` says.
        """
        if protocol["trials"]["order"] == "fixed":
            return "its references are shown in the protocol's order"
        return "its references are shown in an order randomised per participant"

    # --- state ------------------------------------------------------------------------

    def _new_trial(self) -> None:
        self.values = {side: float(self.starts[side]) for side in self.sides}
        self.selected = self.sides[0]
        self.adjustments = 0
        self.answers: list[bool] = []
        self.answer_times: list[float] = []  # each answer's time from the press before it
        self.last_press_time = 0.0
        self.confirm_time = 0.0

    @property
    def done(self) -> bool:
        return self.phase == "done"

    @property
    def order(self) -> list[str]:
        """The trial order, ``block:method:level``, for the sidecar."""
        return [f"{t['block']}:{t['method']}:{t['level']}" for t in self.trials]

    @property
    def total_trials(self) -> int:
        return len(self.trials)

    def key_legend(self) -> list[tuple[str, str]]:
        legend = (
            [
                ("← →", "select the left (darker) or right (brighter) target"),
                ("↑ ↓", "make the selected target brighter or darker"),
            ]
            if self.bounds
            else [("↑ ↓", "make the target brighter or darker")]
        )
        legend += [
            ("Page Up / Page Down", "the same in fine steps"),
            ("", "one step a press: holding a key down does not repeat it"),
            ("Enter", "confirm" + (" both settings" if self.bounds else " the setting")),
        ]
        if self.questions:
            legend.append(("Y / N", "answer yes or no to the questions after each trial"))
        return legend

    def _keys(self) -> dict[str, str]:
        keys = {k: f"{v} step" for k, v in STEP_KEYS.items()}
        if self.bounds:
            keys |= {"left": "select the left target", "right": "select the right target"}
        return keys | {"return": "confirm"}

    def screen(self) -> dict:
        if self.phase == "instructions":
            return {
                "kind": "instructions",
                "text": self.protocol["instructions"]["text"],
                "keys": {"space": "start"},
            }
        if self.phase == "done":
            return {"kind": "done", "keys": {}}
        trial = self.trials[self.index]
        base = {"trial": self.index + 1, "block": trial["block"]}
        if self.phase in ("adjust", "question"):
            reference = {
                "role": "reference",
                "terms": [(reference_name(trial["method"], trial["level"]), 1.0)],
            }
            targets = {
                side: {"role": side, "terms": target_terms(self.values[side])}
                for side in self.sides
            }
            images = (
                [targets["left"], reference, targets["right"]]
                if self.bounds
                else [reference, targets["right"]]
            )
            labels = {side: LABELS[side] for side in self.sides} if self.bounds else {}
        if self.phase == "question":  # asked with the images as set (Yoshida §4, Table 1)
            number = len(self.answers) + 1
            question = self.questions[len(self.answers)]
            return {
                **base,
                "kind": "question",
                "number": number,
                "question": question["text"],
                "column": question["column"],
                "images": images,
                "labels": labels,
                "prompt": f"Question {number}: {question['text']}\nY = yes     N = no",
                "keys": QUESTION_KEYS,
            }
        if self.phase == "adjust":
            return {
                **base,
                "kind": "adjust",
                "images": images,
                "marker": self.selected if self.bounds else None,
                "labels": labels,
                "settings_cd_m2": dict(self.values),
                "selected": self.selected,
                "keys": self._keys(),
            }
        raise ValueError(f"no screen for the phase {self.phase!r}")

    # --- input ------------------------------------------------------------------------

    def press(self, key: str, t: float = 0.0) -> dict | None:
        """Take a key press (:meth:`glarelab.experiments.engine.Engine.press`).

        Parameters
        ----------
        key
            The key's name as the screen takes it
            (:func:`glarelab.experiments.engine.normalise_key`).
        t
            When it went down, s after the onset of the current trial's stimulus; default 0.

        Returns
        -------
        dict or None
            The finished trial's row (column → value) when the press ended a trial, else None.
        """
        if self.phase == "instructions":
            if key == "space":
                self.phase = "adjust" if self.trials else "done"
            return None
        if self.phase == "adjust":
            step = {
                "up": self.coarse,
                "down": -self.coarse,
                "pageup": self.fine,
                "pagedown": -self.fine,
            }
            if key in ("left", "right") and self.bounds:
                self.selected = key
            elif key in step:
                before = self.values[self.selected]
                self.values[self.selected] = min(max(before + step[key], self.low), self.high)
                self.adjustments += self.values[self.selected] != before
            elif key == "return":
                self.confirm_time = self.last_press_time = t
                if not self.questions:
                    return self._finish()
                self.phase = "question"
            return None
        if self.phase == "question":
            if key in ("y", "n"):
                self.answers.append(key == "y")
                self.answer_times.append(max(t - self.last_press_time, 0.0))
                self.last_press_time = t
                if len(self.answers) == len(self.questions):
                    return self._finish()
            return None
        return None

    def _finish(self) -> dict:
        trial = self.trials[self.index]
        settings = (
            {
                "darker_cd_m2": self.values["left"],
                "brighter_cd_m2": self.values["right"],
                "match_cd_m2": (self.values["left"] + self.values["right"]) / 2,
            }
            if self.bounds
            else {"match_cd_m2": self.values["right"]}
        )
        row = {
            "study": self.study,
            "participant": self.participant,
            "session": self.session,
            "trial": self.index + 1,
            "block": trial["block"],
            "time_s": self.confirm_time,
            "method": trial["method"],
            "level": trial["level"],
            "level_index": trial["level_index"],
            "l_disk_cd_m2": trial["l_disk_cd_m2"],
            **settings,
            "adjustments": self.adjustments,
        }
        for question, answer, seconds in zip(
            self.questions, self.answers, self.answer_times, strict=True
        ):
            row[question["column"]] = answer
            row[f"{question['column']}_time_s"] = seconds
        self.index += 1
        self.phase = "adjust" if self.index < len(self.trials) else "done"
        self._new_trial()
        return row

    def replay(self, rows: list[dict]) -> None:
        """Continue after ``rows`` already recorded (trials are independent: skip them).

        Parameters
        ----------
        rows
            The rows already on disk, in order, as :func:`glarelab.experiments.data.read_rows`
            reads them.
        """
        if rows:
            self.index = len(rows)
            self.phase = "adjust" if self.index < len(self.trials) else "done"


class MatchingObserver(LookingObserver):
    """A simulated observer of a matching study: looks at each reference as the display shows
    it (:mod:`glarelab.observers`), sets the targets around the brightness it
    perceives and answers the questions from the glow, the ring or the sizes it sees.

    Parameters
    ----------
    protocol
        A matching protocol; its ``[observer]`` table may change the model's and the noise's
        parameters (:func:`glarelab.observers.noise.observer_parameters`).
    participant
        Its id (with ``seed``, it fixes the observer's gain and every trial's noise).
    seed
        The simulation's seed.
    stimuli
        The stimulus set it looks at, or the set as displayed
        (:class:`glarelab.observers.looking.ObservedSet`, shared by observers to share
        percepts).
    """

    NOISE_KEYS = frozenset(
        {"gain_sd", "setting_sd", "margin", "glow_criterion", "glow_criterion_sd",
         "ring_criterion", "ring_criterion_sd", "size_tolerance", "size_tolerance_sd"}
    )  # fmt: skip

    @staticmethod
    def judged(protocol: Protocol | Mapping[str, Any], geometry: dict):
        """Each method's references, their levels over the clamp ``L_dmax``, the disk of
        ``geometry["disk_diameter_deg"]``, the background, the pixel size, the display's bit
        depth and the room's light
        (:meth:`glarelab.experiments.engine.LookingObserver.judged`).

        Parameters
        ----------
        protocol : glarelab.protocols.Protocol
            The study's protocol (or its data as a mapping): its ``[glare]`` table's
            ``l_dmax_cd_m2`` (cd/m²) and ``methods``, its ``[background]`` table, its
            ``[display]`` table's ``black_cd_m2`` and ``bit_depth`` and its ``[viewing]``
            table's ``room_lux``.
        geometry
            The stimulus set's geometry (its manifest's ``geometry``): ``disk_diameter_deg``
            and ``pixel_deg`` (deg).

        Returns
        -------
        glarelab.observers.fitted_range.JudgedStimuli
            What the observers judge.
        """
        from glarelab.observers.fitted_range import (
            JudgedGlare,
            JudgedStimuli,
            judged_background,
        )

        glare = protocol["glare"]
        clamp = glare["l_dmax_cd_m2"]
        background = judged_background(
            "background",
            protocol["background"],
            disk_cd_m2=clamp,
            black_cd_m2=protocol["display"]["black_cd_m2"],
        )
        return JudgedStimuli(
            tuple(
                JudgedGlare(
                    f"method {method['name']!r}",
                    method["model"],
                    method.get("parameters"),
                    tuple(level / clamp for level in method["levels_cd_m2"]),
                )
                for method in glare["methods"]
            ),
            disk_cd_m2=clamp,
            disk_diameter_deg=geometry["disk_diameter_deg"],
            backgrounds=(background,),
            pixel_deg=geometry["pixel_deg"],
            bit_depth=protocol["display"]["bit_depth"],
            room_lux=protocol["viewing"]["room_lux"],
        )

    def __init__(self, protocol: Protocol, participant: str, *, seed: int, stimuli):
        super().__init__(protocol, participant, seed=seed, stimuli=stimuli)
        g = self.display.geometry
        self.geometry = {
            "centre_px": tuple(g["centre_px"]),
            "diameter_deg": g["disk_diameter_deg"],
            "pixel_deg": g["pixel_deg"],
        }
        t = protocol["trials"]
        self.coarse, self.fine = t["coarse_step_cd_m2"], t["fine_step_cd_m2"]
        self.questions = protocol["questionnaire"]["questions"]
        self._targets: dict[int, float] = {}  # the brighter (or only) setting per trial
        self._references: dict[int, list] = {}
        self._confirmed: dict[int, float] = {}  # the Enter's time, from the trial's onset

    def _percept(self, terms):
        return self.display.percept(self.model, terms, **self.geometry)

    def _rng(self, screen: dict) -> np.random.Generator:
        return participant_rng(
            self.protocol.seed,
            self.participant,
            f"observer {self.seed} trial {screen['trial']} {screen['kind']} "
            f"{screen.get('number', 0)}",
        )

    def keys(self, screen: dict) -> list[tuple[str, float]]:
        """The key presses (with times from the trial's onset) that answer ``screen``.

        Parameters
        ----------
        screen
            The engine's screen to answer. (``adjust`` or ``question``).

        Returns
        -------
        list of tuple of (str, float)
            ``(key, seconds from the onset)`` of each press, in order.

        Raises
        ------
        ValueError
            For a screen of another kind.
        """
        rng = self._rng(screen)
        if screen["kind"] == "adjust":
            return self._adjust(screen, rng)
        if screen["kind"] == "question":
            return self._answer(screen, rng)
        raise ValueError(f"a matching observer cannot answer a {screen['kind']!r} screen")

    def _adjust(self, screen: dict, rng: np.random.Generator) -> list[tuple[str, float]]:
        images = {image["role"]: image for image in screen["images"]}
        reference = self._percept(images["reference"]["terms"])
        darker, brighter = self.observer.settings(reference, rng)
        wanted = (
            {"left": darker, "right": brighter}
            if "left" in images
            else {"right": (darker + brighter) / 2}
        )
        self._targets[screen["trial"]] = wanted["right"]
        self._references[screen["trial"]] = images["reference"]["terms"]
        keys: list[tuple[str, float]] = []
        clock = 0.0
        for side, value in wanted.items():
            if "left" in images:
                clock += 0.5
                keys.append((side, clock))
            change = value - screen["settings_cd_m2"][side]
            coarse = int(abs(change) // self.coarse)
            fine = round((abs(change) - coarse * self.coarse) / self.fine)
            up = change > 0
            for _ in range(coarse):
                clock += 0.15
                keys.append(("up" if up else "down", clock))
            for _ in range(fine):
                clock += 0.25
                keys.append(("pageup" if up else "pagedown", clock))
        keys.append(("return", clock + 1.0 + float(rng.exponential(2.0))))
        self._confirmed[screen["trial"]] = keys[-1][1]
        return keys

    def _answer(self, screen: dict, rng: np.random.Generator) -> list[tuple[str, float]]:
        from glarelab.stimuli.matching import target_terms

        trial = screen["trial"]
        question = self.questions[screen["number"] - 1]
        reference = self._percept(self._references[trial])
        target = self._percept(target_terms(round(self._targets[trial])))
        glow, ring, same = self.observer.answers(reference, target, rng)
        measure = question["simulated_by"]
        answer = {"glow": glow, "ring": ring, "same_size": same}.get(measure)
        if answer is None:
            answer = bool(rng.random() < 0.5)
        # half a second per question after the Enter (times are from the trial's onset)
        return [("y" if answer else "n", self._confirmed[trial] + 0.5 * screen["number"])]
