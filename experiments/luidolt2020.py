"""The 7-point Likert questionnaire of Luidolt (2020, §7.2.1).

Six categories (glare appearance, glare movement, eye adaptation, visual acuity, scotopic
vision, overall), each rated from 1 = completely different to 7 = exactly the same with the
number keys, then an optional comment (typed into a text box, which keeps case and punctuation;
``return`` records it, or skips when empty). One row per category; ``time_s`` is the time from
the rating screen's onset to the rating key.
"""

from __future__ import annotations

from .engine import Engine, normalise_key

__all__ = ["LikertQuestionnaire"]


class LikertQuestionnaire(Engine):
    """The Luidolt 2020 questionnaire engine (no PsychoPy)."""

    study = "luidolt2020"

    def __init__(self, protocol, participant: str, *, session: int = 1):
        q = protocol["questionnaire"]
        self.protocol = protocol
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
        if self.phase == "rate":
            keys = {str(r): f"rate {r}" for r in range(self.low, self.high + 1) if r < 10}
            return {**base, "kind": "rate", "keys": keys}
        return {
            **base,
            "kind": "comment",
            "rating": self.rating,
            "typed": self.typed,
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
