"""Brightness matching by adjustment (Yoshida et al. 2008, §4).

After the instructions and a training block, each of the 12 references (6 levels × 2 methods)
is shown once, in an order randomised per participant (seeded, recorded). A trial shows the
reference in the middle and two glare-free targets left and right, starting at 100 and 400
cd/m². The participant selects a target (``left``/``right``; a bar under it marks it), adjusts
its disk luminance (``up``/``down`` coarse, ``pageup``/``pagedown`` fine; the display's range
bounds it) and confirms with ``return`` when the left disk looks slightly but visibly darker and
the right slightly but visibly brighter than the reference. Three yes/no questions follow
(``y`` / ``n``, Table 1). The row holds both settings, their mean (the match), the answers, the
number of adjustments and the time from the reference's onset to the confirming Enter.
"""

from __future__ import annotations

from .engine import Engine, participant_rng

__all__ = ["BrightnessMatching"]

QUESTION_COLUMNS = ("q1_glow", "q2_ring", "q3_same_size")
ADJUST_KEYS = {
    "left": "select the left target (slightly darker)",
    "right": "select the right target (slightly brighter)",
    "up": "selected target brighter (coarse step)",
    "down": "selected target darker (coarse step)",
    "pageup": "brighter (fine step)",
    "pagedown": "darker (fine step)",
    "return": "confirm both settings",
}
QUESTION_KEYS = {"y": "yes", "n": "no"}


class BrightnessMatching(Engine):
    """The Yoshida 2008 protocol engine (no PsychoPy)."""

    study = "yoshida2008"

    def __init__(self, protocol, participant: str, *, session: int = 1):
        self.protocol = protocol
        self.participant = participant
        self.session = session
        g, t = protocol["glare"], protocol["trials"]
        display = protocol["display"]
        self.low, self.high = display["black_cd_m2"], display["max_cd_m2"]
        self.coarse, self.fine = t["coarse_step_cd_m2"], t["fine_step_cd_m2"]
        self.starts = protocol["stimulus"]["target_start_cd_m2"]
        self.questions = protocol["questionnaire"]["questions"]
        references = [
            {"method": m, "level": label, "level_index": i + 1, "l_disk_cd_m2": level}
            for m in ("gaussian", "vos")
            for i, (label, level) in enumerate(
                zip(g[m]["labels"], g[m]["levels_cd_m2"], strict=True)
            )
        ]
        rng = participant_rng(protocol.seed, participant, "yoshida2008 order")
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

    # --- state ------------------------------------------------------------------------

    def _new_trial(self) -> None:
        self.values = {"left": float(self.starts[0]), "right": float(self.starts[1])}
        self.selected = "left"
        self.adjustments = 0
        self.answers: list[bool] = []
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
        legend = [
            ("← →", "select the left (darker) or right (brighter) target"),
            ("↑ ↓", "make the selected target brighter or darker"),
            ("Page Up / Page Down", "the same in fine steps"),
            ("Enter", "confirm both settings"),
        ]
        if self.questions:
            legend.append(("Y / N", "answer yes or no to the questions after each trial"))
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
        trial = self.trials[self.index]
        base = {
            "trial": self.index + 1,
            "block": trial["block"],
            "reference": f"reference_{trial['method']}_{trial['level']}",
        }
        if self.phase == "adjust":
            return {
                **base,
                "kind": "adjust",
                "left_cd_m2": self.values["left"],
                "right_cd_m2": self.values["right"],
                "selected": self.selected,
                "keys": ADJUST_KEYS,
            }
        return {
            **base,
            "kind": "question",
            "keys": QUESTION_KEYS,
            "question": self.questions[len(self.answers)],
            "number": len(self.answers) + 1,
        }

    # --- input ------------------------------------------------------------------------

    def press(self, key: str, t: float = 0.0) -> dict | None:
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
            if key in ("left", "right"):
                self.selected = key
            elif key in step:
                before = self.values[self.selected]
                self.values[self.selected] = min(max(before + step[key], self.low), self.high)
                self.adjustments += self.values[self.selected] != before
            elif key == "return":
                self.confirm_time = t
                if not self.questions:
                    return self._finish()
                self.phase = "question"
            return None
        if self.phase == "question":
            if key in ("y", "n"):
                self.answers.append(key == "y")
                if len(self.answers) == len(self.questions):
                    return self._finish()
            return None
        return None

    def _finish(self) -> dict:
        trial = self.trials[self.index]
        left, right = self.values["left"], self.values["right"]
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
            "darker_cd_m2": left,
            "brighter_cd_m2": right,
            "match_cd_m2": (left + right) / 2,
            "adjustments": self.adjustments,
        }
        for name, answer in zip(QUESTION_COLUMNS, self.answers, strict=False):
            row[name] = answer
        self.index += 1
        self.phase = "adjust" if self.index < len(self.trials) else "done"
        self._new_trial()
        return row

    def replay(self, rows: list[dict]) -> None:
        """Continue after ``rows`` already recorded (trials are independent: skip them)."""
        if rows:
            self.index = len(rows)
            self.phase = "adjust" if self.index < len(self.trials) else "done"
