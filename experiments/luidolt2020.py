"""The 7-point Likert questionnaire of Luidolt (2020, §7.2.1).

Six categories (glare appearance, glare movement, eye adaptation, visual acuity, scotopic
vision, overall), each rated from 1 = completely different to 7 = exactly the same with the
number keys, then an optional comment (typed; ``return`` records it, or skips when empty).
One row per category.
"""

from __future__ import annotations

__all__ = ["LikertQuestionnaire"]


class LikertQuestionnaire:
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

    def screen(self) -> dict:
        if self.phase in ("instructions", "done"):
            return {"kind": self.phase, "text": self.protocol["instructions"]["text"]}
        base = {
            "trial": self.index + 1,
            "category": self.categories[self.index],
            "prompt": self.prompts[self.index],
            "anchors": self.protocol["questionnaire"]["anchors"],
            "scale": (self.low, self.high),
        }
        if self.phase == "rate":
            return {**base, "kind": "rate"}
        return {**base, "kind": "comment", "rating": self.rating, "typed": self.typed}

    def press(self, key: str, t: float = 0.0) -> dict | None:
        if self.phase == "instructions":
            if key == "space":
                self.phase = "rate"
            return None
        if self.phase == "rate":
            digit = key.removeprefix("num_")
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
            if key == "backspace":
                self.typed = self.typed[:-1]
            elif key == "space":
                self.typed += " "
            elif len(key) == 1:
                self.typed += key
            return None
        return None

    def type_text(self, text: str) -> None:
        """Enter a whole comment at once (front-ends with a text box, observers)."""
        if self.phase == "comment":
            self.typed += text

    def _finish(self) -> dict:
        row = {
            "study": self.study,
            "participant": self.participant,
            "session": self.session,
            "trial": self.index + 1,
            "block": "questionnaire",
            "time_s": self.time,
            "dropped_frames": 0,
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
