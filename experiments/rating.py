"""A rating questionnaire (Luidolt 2020, §7.2.1: a 7-point Likert scale): the engine.

Each category (Luidolt: glare appearance, glare movement, eye adaptation, visual acuity,
scotopic vision, overall) is rated on the protocol's scale (Luidolt: 1 = completely different
to 7 = exactly the same) with the number keys, then an optional comment (typed into a text
box, which keeps case and punctuation; ``return`` records it, or skips when empty). One row per
category; ``time_s`` is the time from the rating screen's onset to the rating key.
"""

from __future__ import annotations

import numpy as np

from .engine import Engine, normalise_key, participant_rng

__all__ = ["RatingEngine", "RatingObserver"]


class RatingEngine(Engine):
    """The engine of a rating protocol (no PsychoPy)."""

    def __init__(
        self,
        protocol,
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
        self.categories = q["categories"]
        self.prompts = q["prompts"]
        self.low, self.high = q["scale_min"], q["scale_max"]
        self.comments = q["comments"]
        self.index = 0
        self.phase = "instructions"
        self.rating: int | None = None
        self.typed = ""

    @property
    def done(self) -> bool:
        return self.phase == "done"

    @property
    def total_trials(self) -> int:
        return len(self.categories)

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
            "category": self.categories[self.index],
            "prompt": self.prompts[self.index],
            "anchors": self.protocol["questionnaire"]["anchors"],
            "scale": (self.low, self.high),
        }
        low, high = base["anchors"]
        if self.phase == "rate":
            keys = {str(r): f"rate {r}" for r in range(self.low, self.high + 1)}
            text = (
                f"{base['category']}\n\n{base['prompt']}\n\n{self.low} = {low}   …   "
                f"{self.high} = {high}\n\nPress a number key from {self.low} to {self.high}."
            )
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

    def press(self, key: str, t: float = 0.0) -> dict | None:
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
        """The comment as typed into the front-end's text box (kept verbatim)."""
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
            "category": self.categories[self.index],
            "rating": self.rating,
            "comment": self.typed.strip() or None,
        }
        self.index += 1
        self.rating, self.typed = None, ""
        self.phase = "rate" if self.index < len(self.categories) else "done"
        return row

    def replay(self, rows: list[dict]) -> None:
        if rows:
            self.index = len(rows)
            self.phase = "rate" if self.index < len(self.categories) else "done"


class RatingObserver:
    """A simulated participant of a rating study: each category's rating drawn from the
    protocol's ``observer.ratings`` (every rating alike where a category has none), and no
    comment.

    Parameters
    ----------
    protocol, participant, seed
        The study, who, and the simulation's seed (they fix every rating).
    stimuli
        Unused: a questionnaire shows no images.
    """

    @staticmethod
    def check(protocol) -> None:
        """Nothing to check here: the protocol checks ``observer.ratings`` when it loads."""

    def __init__(self, protocol, participant: str, *, seed: int, stimuli=None):
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

    def expected(self, category: str) -> float:
        """The expected rating of a category."""
        return float(self.scale @ self.probabilities[category])

    def keys(self, screen: dict) -> list[tuple[str, float]]:
        """The rating key (with its time from the screen's onset), or Enter on a comment."""
        rng = participant_rng(
            self.protocol.seed,
            self.participant,
            f"observer {self.seed} trial {screen['trial']} {screen['kind']}",
        )
        if screen["kind"] == "rate":
            rating = int(rng.choice(self.scale, p=self.probabilities[screen["category"]]))
            return [(str(rating), 5.0 + float(rng.exponential(5.0)))]
        if screen["kind"] == "comment":
            return [("return", 1.0)]
        raise ValueError(f"a rating observer cannot answer a {screen['kind']!r} screen")
