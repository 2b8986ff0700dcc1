"""Three-way forced choice with interleaved staircases (Spencer et al. 1995, §4).

Two blocks, without and with context, in an order counterbalanced across participants
(``counterbalance`` 0: no context first; 1: the lamp first). In each block one staircase per
glare level runs on the comparison disc's intensity (0-100 % of the display maximum),
interleaved in a seeded random order. A trial shows the glare image and the disc-and-annulus
image side by side, sides swapped at random, for 400 or 700 ms (chosen at random per trial;
an exact number of frames at the display's refresh rate) after a blank of ``inter_trial_ms``,
then asks: ``left`` brighter, ``right`` brighter, or ``down`` for neither (an answer during the
flash counts). A flash that dropped frames or missed its timing is recorded with
``presentation_ok`` false; with ``repeat_failed_presentations`` it does not move its staircase
(``counted`` false) and the same staircase is shown again.

Each staircase starts at ``start_fraction`` and moves the disc up when the glare image looked
brighter and down when the disc did, by ``step_fractions[k]`` once it has had ``k`` reversals
(the last step is kept; as in PsychoPy's ``StairHandler``, the reversing move already takes the
smaller step). **Neither** means the two looked equally bright, a point of equality, and
always counts as a reversal, which guarantees the staircase ends:

- ``hold``: the disc stays where it is;
- ``alternate``: the disc steps against the staircase's last direction (bracketing).

A staircase ends after ``reversals`` reversals (or 4 × reversals + 20 trials, whichever is
first). The analysis estimates the match from the reversal points.

PsychoPy's ``StairHandler`` is not used: it models two-outcome responses (correct/incorrect),
has no third answer, and importing it would put PsychoPy into this screen-free engine.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from .engine import Engine, participant_rng

__all__ = ["Staircase", "StaircaseExperiment"]

RESPONSE_KEYS = ("left", "right", "down")


@dataclass
class Staircase:
    """One staircase on the disc intensity (fraction of the display maximum)."""

    level: int
    strength: float
    fraction: float
    steps: tuple[float, ...]
    reversals_needed: int
    neither: str
    direction: int = 0  # +1 up, -1 down, 0 not moved yet
    reversals: int = 0
    trials: int = 0
    history: list = field(default_factory=list)

    @property
    def step(self) -> float:
        return self.steps[min(self.reversals, len(self.steps) - 1)]

    @property
    def done(self) -> bool:
        return (
            self.reversals >= self.reversals_needed
            or self.trials >= 4 * self.reversals_needed + 20
        )

    def update(self, response: str) -> bool:
        """Apply a response ('glare', 'disc', 'neither'); return whether it was a reversal."""
        self.trials += 1
        if response == "glare":
            move = +1
        elif response == "disc":
            move = -1
        elif response == "neither":
            move = 0 if self.neither == "hold" else (-self.direction or +1)
        else:
            raise ValueError(f"response must be 'glare', 'disc' or 'neither'; got {response!r}")
        reversal = response == "neither" or (self.direction != 0 and move == -self.direction)
        if reversal:  # as PsychoPy's StairHandler: the reversing move already takes the next step
            self.reversals += 1
        if move:
            self.fraction = min(max(self.fraction + move * self.step, 0.0), 1.0)
            self.direction = move
        self.history.append((response, reversal))
        return reversal


class StaircaseExperiment(Engine):
    """The Spencer 1995 protocol engine (no PsychoPy)."""

    study = "spencer1995"

    def __init__(
        self,
        protocol,
        participant: str,
        *,
        session: int = 1,
        counterbalance: int,
        refresh_hz: float,
    ):
        if counterbalance not in (0, 1):
            raise ValueError(f"counterbalance must be 0 or 1; got {counterbalance!r}")
        if not refresh_hz > 0:
            raise ValueError(f"refresh_hz must be > 0; got {refresh_hz!r}")
        self.protocol = protocol
        self.participant = participant
        self.session = session
        self.refresh_hz = refresh_hz
        contexts = list(protocol["stimulus"]["context"])
        self.contexts = contexts if counterbalance == 0 else contexts[::-1]
        self.counterbalance = counterbalance
        self.repeat_failed = protocol["trials"]["repeat_failed_presentations"]
        self.rng = participant_rng(protocol.seed, participant, "spencer1995 trials")
        self.block = 0
        self.trial = 0
        self.phase = "instructions"
        self.presentation_ok = True
        self._start_block()

    def _start_block(self) -> None:
        t, g = self.protocol["trials"], self.protocol["glare"]
        self.staircases = [
            Staircase(
                level=i + 1,
                strength=s,
                fraction=t["start_fraction"],
                steps=tuple(t["step_fractions"]),
                reversals_needed=t["reversals"],
                neither=t["neither"],
            )
            for i, s in enumerate(g["strengths"])
        ]
        self._next_trial()

    def _next_trial(self, *, again: bool = False) -> None:
        """Draw the next staircase (or keep the current one, ``again``), its side and time."""
        if not again:
            open_ = [s for s in self.staircases if not s.done]
            if not open_:
                self.current = None
                return
            self.current = open_[int(self.rng.integers(len(open_)))]
        self.glare_side = ("left", "right")[int(self.rng.integers(2))]
        durations = self.protocol["trials"]["presentation_ms"]
        self.duration_ms = float(durations[int(self.rng.integers(len(durations)))])
        self.frames = max(1, round(self.duration_ms * self.refresh_hz / 1000.0))
        self.presentation_ok = True

    @property
    def done(self) -> bool:
        return self.phase == "done"

    @property
    def context(self) -> str:
        return self.contexts[self.block]

    def key_legend(self) -> list[tuple[str, str]]:
        return [
            ("←", "the LEFT light looked brighter"),
            ("→", "the RIGHT light looked brighter"),
            ("↓", "NEITHER looked brighter"),
            ("", "you may answer during the flash or after it"),
        ]

    def screen(self) -> dict:
        if self.phase == "instructions":
            return {
                "kind": "instructions",
                "text": self.protocol["instructions"]["text"],
                "keys": {"space": "start"},
            }
        if self.phase == "block":
            scene = "alone on a black screen" if self.context == "none" else "in a scene (a lamp)"
            return {
                "kind": "block",
                "text": f"Part {self.block + 1} of {len(self.contexts)}: the light is shown "
                f"{scene}.",
                "keys": {"space": "continue"},
            }
        if self.phase == "done":
            return {"kind": "done", "keys": {}}
        s = self.current
        return {
            "kind": "present",
            "trial": self.trial + 1,
            "block": self.context,
            "glare_image": f"glare_{self.context}_{s.level:02d}",
            "glare_side": self.glare_side,
            "disc_fraction": s.fraction,
            "frames": self.frames,
            "duration_ms": self.duration_ms,
            "blank_before_ms": self.protocol["trials"]["inter_trial_ms"],
            "context": self.context,
            "keys": {
                "left": "left looked brighter",
                "right": "right looked brighter",
                "down": "neither",
            },
        }

    def presented(self, ok: bool) -> None:
        self.presentation_ok = bool(ok)

    def press(self, key: str, t: float = 0.0) -> dict | None:
        if self.phase in ("instructions", "block"):
            if key == "space":
                self.phase = "trial"
            return None
        if self.phase != "trial" or key not in RESPONSE_KEYS:
            return None
        if key == "down":
            response = "neither"
        else:
            response = "glare" if key == self.glare_side else "disc"
        return self._respond(response, t, presentation_ok=self.presentation_ok)

    def _respond(self, response: str, t: float, *, presentation_ok: bool) -> dict:
        s = self.current
        tested = s.fraction
        counted = presentation_ok or not self.repeat_failed
        reversal = s.update(response) if counted else False
        self.trial += 1
        row = {
            "study": self.study,
            "participant": self.participant,
            "session": self.session,
            "trial": self.trial,
            "block": self.context,
            "time_s": t,
            "context": self.context,
            "glare_level": s.level,
            "strength": s.strength,
            "duration_ms": self.duration_ms,
            "frames": self.frames,
            "glare_side": self.glare_side,
            "disc_fraction": tested,
            "response": response,
            "reversal": reversal,
            "step_fraction": s.step,
            "presentation_ok": presentation_ok,
            "counted": counted,
        }
        self._next_trial(again=not counted)
        if self.current is None:
            self.block += 1
            if self.block < len(self.contexts):
                self._start_block()
                self.phase = "block"
            else:
                self.phase = "done"
        return row

    def replay(self, rows: list[dict]) -> None:
        """Rebuild every staircase from the recorded responses, then continue."""
        if rows and self.phase == "instructions":
            self.phase = "trial"
        for row in rows:
            if self.phase == "block":
                self.phase = "trial"
            expected = self.screen()
            level = int(row["glare_level"])
            if (
                expected.get("kind") != "present"
                or self.current.level != level
                or row["context"] != self.context
            ):
                raise ValueError(
                    f"the recorded trial {row['trial']} (level {level}, {row['context']}) does "
                    "not follow this participant's seeded order; was the protocol or seed changed?"
                )
            ok = str(row.get("presentation_ok", "true")).lower() == "true"
            self._respond(row["response"], float(row["time_s"]), presentation_ok=ok)
