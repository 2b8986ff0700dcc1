"""A rating questionnaire (Luidolt 2020, §7.2.1: a 7-point Likert scale): the engine.

Each category (Luidolt: glare appearance, glare movement, eye adaptation, visual acuity,
scotopic vision, overall) is rated on the protocol's scale (Luidolt: 1 = completely different
to 7 = exactly the same) with the number keys, then an optional comment (typed into a text
box, which keeps case and punctuation; ``return`` records it, or skips when empty). One row per
category; ``time_s`` is the time from the rating screen's onset to the rating key.

With a scene and conditions, the questionnaire rates what is shown: each condition (in an order
of its own per participant) begins with a timed presentation of its frames (the scene still,
or a sequence, each frame for a whole number of refreshes), after which the first category's
question appears; keys pressed while the scene shows are not taken (they are recorded as
ignored). That row's timing columns are the presentation's (onset, offset, frames dropped;
``time_s`` from the scene's onset). The rows name the condition. A live scene
(``scene.live``) is a free-viewing period of ``scene.seconds`` instead, which the front-end
renders per refresh for the eye tracker's gaze (:mod:`glarelab.frontend.live`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from glarelab.experiments.engine import Engine, normalise_key, participant_rng

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["RatingEngine", "RatingObserver", "shift_down"]


class RatingEngine(Engine):
    """The engine of a rating protocol (no PsychoPy).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.
    participant
        The participant's id (it seeds the participant's orders).
    session
        The session's number, from 1; default 1.
    counterbalance
        Not used: the categories are asked in the protocol's order, the conditions' (if any)
        in an order randomised per participant. Default None.
    refresh_hz
        The display's refresh rate, Hz, > 0: how many refreshes each frame of the scene
        stays on (:func:`glarelab.stimuli.night.night_plan`). Default 60.
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
        q = protocol["questionnaire"]
        self.protocol = protocol
        self.study = protocol.study
        self.participant = participant
        self.session = session
        conditions = [c["name"] for c in protocol.data.get("conditions") or []]
        if conditions:  # an order of the participant's own, the same in every run
            order = participant_rng(protocol.seed, participant, "conditions").permutation(
                len(conditions)
            )
            conditions = [conditions[i] for i in order]
        self.conditions = conditions or [None]
        self.categories = q["categories"]
        self.prompts = q["prompts"]
        self.low, self.high = q["scale_min"], q["scale_max"]
        self.comments = q["comments"]
        self.refresh_hz = refresh_hz
        self.index = 0
        self.phase = "instructions"
        self.rating: int | None = None
        self.typed = ""

    @classmethod
    def ordered(cls, protocol: Protocol) -> str:
        """The categories' order, always the protocol's; the conditions' (if any), randomised
        per participant.

        Parameters
        ----------
        protocol : glarelab.protocols.Protocol
            The study's protocol (its ``conditions``).

        Returns
        -------
        str
            The clause :func:`glarelab.experiments.session.check_counterbalance` says.
        """
        if protocol.data.get("conditions"):
            return (
                "its conditions come in an order randomised per participant, the categories "
                "of each in the protocol's order"
            )
        return "its categories are always asked in the protocol's order"

    @property
    def done(self) -> bool:
        return self.phase == "done"

    @property
    def total_trials(self) -> int:
        return len(self.categories) * len(self.conditions)

    @property
    def condition(self) -> str | None:
        return self.conditions[self.index // len(self.categories)]

    @property
    def category_index(self) -> int:
        return self.index % len(self.categories)

    def key_legend(self) -> list[tuple[str, str]]:
        legend = [(f"{self.low} … {self.high}", "your rating (number keys)")]
        if self.comments:
            legend.append(("Enter", "after typing a comment (or with none) goes on"))
        return legend

    def screen(self) -> dict:
        if self.phase == "instructions":
            return {
                "kind": "instructions",
                "text": self.protocol["instructions"]["text"],
                "keys": {"space": "start"},
            }
        if self.phase == "done":
            return {"kind": "done", "keys": {}}
        base = {
            "trial": self.index + 1,
            "category": self.categories[self.category_index],
            "question": self.prompts[self.category_index],  # drawn once, in the screen's text
            "anchors": self.protocol["questionnaire"]["anchors"],
            "scale": (self.low, self.high),
        }
        if self.condition is not None:
            base["condition"] = self.condition
        low, high = base["anchors"]
        if self.phase == "rate":
            keys = {str(r): f"rate {r}" for r in range(self.low, self.high + 1)}
            text = (
                f"{base['category']}\n\n{base['question']}\n\n{self.low} = {low}   …   "
                f"{self.high} = {high}\n\nPress a number key from {self.low} to {self.high}."
            )
            if self.condition is not None and self.category_index == 0:
                return {**base, **self._presentation(), "prompt": text, "keys": keys}
            return {**base, "kind": "rate", "text": text, "keys": keys}
        return {
            **base,
            "kind": "comment",
            "rating": self.rating,
            "typed": self.typed,
            "text": f"{base['category']}: rated {self.rating}\n\nComment (optional); press "
            "Enter when done:",
            "keys": {"return": "finish the comment"},
            "text_entry": True,
        }

    def _presentation(self) -> dict:
        """The condition's frames, each for its refreshes (a still: all of them); a live scene:
        the free-viewing period, every refresh rendered for the gaze by the front-end."""
        scene = self.protocol["scene"]
        if scene["live"]:
            effects = next(
                c["effects"] for c in self.protocol["conditions"] if c["name"] == self.condition
            )
            return {
                "kind": "present",
                "condition": self.condition,
                "live": {"effects": list(effects), "seconds": scene["seconds"]},
                "images": [],
                "frames": max(1, round(scene["seconds"] * self.refresh_hz)),
                "blank_before_ms": scene["blank_before_ms"],
                "answer_after_presentation": True,
            }
        sequence = self.sequences[self.condition]
        frames = [
            {
                "images": [{"role": "scene", "terms": [[name, 1.0]]}],
                "frames": sequence["refreshes_per_frame"],
            }
            for name in sequence["frames"]
        ]
        return {
            "kind": "present",
            "condition": self.condition,
            "sequence": frames,
            "images": frames[0]["images"],
            "frames": sum(f["frames"] for f in frames),
            "blank_before_ms": self.protocol["scene"]["blank_before_ms"],
            "answer_after_presentation": True,  # the question comes after the scene
        }

    @property
    def sequences(self) -> dict:
        """Condition → its frame names and refreshes
        (:func:`glarelab.stimuli.night.build_night`)."""
        if not hasattr(self, "_sequences"):
            from glarelab.stimuli.night import night_plan

            self._sequences = night_plan(self.protocol, self.refresh_hz)
        return self._sequences

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
                self.phase = "rate"
            return None
        if self.phase == "rate":
            digit = normalise_key(key)
            if digit.isdigit() and self.low <= int(digit) <= self.high:
                self.rating = int(digit)
                self.time = t
                if not self.comments:
                    return self._finish()
                self.phase = "comment"
            return None
        if self.phase == "comment":
            if key == "return":
                return self._finish()
            return None
        return None

    def type_text(self, text: str) -> None:
        """The comment as typed into the front-end's text box (kept verbatim).

        Parameters
        ----------
        text
            The comment so far; ignored outside the comment screen.
        """
        if self.phase == "comment":
            self.typed = text

    def _finish(self) -> dict:
        row = {
            "study": self.study,
            "participant": self.participant,
            "session": self.session,
            "trial": self.index + 1,
            "block": "questionnaire",
            "time_s": self.time,
            "category": self.categories[self.category_index],
            "rating": self.rating,
            "comment": self.typed.strip() or None,
        }
        if self.condition is not None:
            row["condition"] = self.condition
        self.index += 1
        self.rating, self.typed = None, ""
        self.phase = "rate" if self.index < self.total_trials else "done"
        return row

    def replay(self, rows: list[dict]) -> None:
        """Continue after the rows already recorded.

        Parameters
        ----------
        rows
            The rows already on disk, in order, as :func:`glarelab.experiments.data.read_rows`
            reads them.
        """
        if rows:
            self.index = len(rows)
            for number, row in enumerate(rows):
                expected = self.conditions[number // len(self.categories)]
                if expected is not None and row.get("condition") != expected:
                    raise ValueError(
                        f"the recorded trial {number + 1} rated condition "
                        f"{row.get('condition')!r} where this participant's seeded order has "
                        f"{expected!r}; was the protocol or seed changed?"
                    )
            self.phase = "rate" if self.index < self.total_trials else "done"


class RatingObserver:
    """A simulated participant of a rating study: each category's rating drawn from the
    protocol's ``observer.ratings`` (every rating alike where a category has none), and no
    comment.

    Where a study shows conditions, a category whose effect (``observer.category_effects``) the
    shown condition lacks is rated ``observer.missing_effect_shift`` points lower: the
    distribution is moved down the scale (a fractional shift split between the two ratings
    around it) and what falls below the lowest rating piles up there.

    Parameters
    ----------
    protocol, participant, seed
        The study, who, and the simulation's seed (they fix every rating).
    stimuli
        Unused: the ratings follow the conditions, not the images.
    """

    @staticmethod
    def check(protocol: Protocol) -> None:
        """Nothing to check here: the protocol checks ``observer`` when it loads.

        Parameters
        ----------
        protocol : glarelab.protocols.Protocol
            The study's protocol (not used).
        """

    def __init__(self, protocol: Protocol, participant: str, *, seed: int, stimuli=None):
        q = protocol["questionnaire"]
        self.protocol = protocol
        self.participant = participant
        self.seed = seed
        self.scale = np.arange(q["scale_min"], q["scale_max"] + 1)
        given = protocol["observer"]["ratings"]
        self.probabilities = {
            c: np.asarray(given.get(c, np.full(self.scale.size, 1 / self.scale.size)), float)
            for c in q["categories"]
        }
        self.effects = {
            c["name"]: set(c["effects"]) for c in protocol.data.get("conditions") or []
        }

    def distribution(self, category: str, condition: str | None = None) -> np.ndarray:
        """The probability of each rating of a category, for the condition shown.

        Parameters
        ----------
        category
            A category of ``questionnaire.categories``.
        condition
            The condition shown; default None: none (the category's own distribution).

        Returns
        -------
        numpy.ndarray
            One probability per rating of the scale, summing to 1: the protocol's, moved down by
            ``missing_effect_shift`` when the condition lacks the category's effect
            (:func:`shift_down`).
        """
        p = self.probabilities[category]
        effect = self.protocol["observer"]["category_effects"].get(category)
        if condition is None or effect is None or effect in self.effects[condition]:
            return p
        return shift_down(p, self.protocol["observer"]["missing_effect_shift"])

    def expected(self, category: str, condition: str | None = None) -> float:
        """The expected rating of a category (for the condition shown).

        Parameters
        ----------
        category
            A category of ``questionnaire.categories``.
        condition
            The condition shown; default None: none (the category's own distribution).

        Returns
        -------
        float
            The mean rating, in scale points.
        """
        return float(self.scale @ self.distribution(category, condition))

    def keys(self, screen: dict) -> list[tuple[str, float]]:
        """The rating key (with its time from the screen's onset), or Enter on a comment.

        Parameters
        ----------
        screen
            The engine's screen to answer.

        Returns
        -------
        list of tuple of (str, float)
            ``(key, seconds from the onset)`` of each press, in order.
        """
        rng = participant_rng(
            self.protocol.seed,
            self.participant,
            f"observer {self.seed} trial {screen['trial']} {screen['kind']}",
        )
        if screen["kind"] in ("rate", "present"):
            p = self.distribution(screen["category"], screen.get("condition"))
            rating = int(rng.choice(self.scale, p=p))
            viewing = float(screen.get("live", {}).get("seconds", 0.0))  # answered after it
            return [(str(rating), viewing + 5.0 + float(rng.exponential(5.0)))]
        if screen["kind"] == "comment":
            return [("return", 1.0)]
        raise ValueError(f"a rating observer cannot answer a {screen['kind']!r} screen")


def shift_down(probabilities: np.ndarray, points: float) -> np.ndarray:
    """A rating distribution moved ``points`` (>= 0) down its scale; a fractional shift is
    split between the two ratings around it, and what falls below the first rating stays there.

    Parameters
    ----------
    probabilities
        One probability per rating, lowest first.
    points
        The shift, scale points, >= 0.

    Returns
    -------
    numpy.ndarray
        The shifted distribution, the same sum.

    Examples
    --------
    >>> shift_down(np.array([0.0, 0.0, 1.0]), 1.5).tolist()
    [0.5, 0.5, 0.0]
    """
    p = np.asarray(probabilities, dtype=float)
    whole, part = int(np.floor(points)), float(points - np.floor(points))
    out = np.zeros_like(p)
    for index, value in enumerate(p):
        for step, weight in ((whole, 1.0 - part), (whole + 1, part)):
            out[max(index - step, 0)] += value * weight
    return out
