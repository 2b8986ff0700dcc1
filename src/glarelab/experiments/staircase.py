"""Three-way forced choice with interleaved staircases (Spencer et al. 1995, §4): the engine.

One block per context (Spencer: without and with context), in an order counterbalanced across
participants (``counterbalance`` 0: the protocol's order; 1: reversed). In each block one
staircase per
glare level runs on the comparison disc's intensity (0-100 % of the display maximum),
interleaved in a seeded random order. A trial shows the glare image and the disc-and-annulus
image side by side, sides swapped at random, for 400 or 700 ms (chosen at random per trial;
an exact number of frames at the display's refresh rate) after a blank of ``inter_trial_ms``,
then asks: ``left`` brighter, ``right`` brighter, or ``down`` for neither (an answer during the
flash counts). A flash that dropped frames or missed its timing is recorded with
``presentation_ok`` false; with ``repeat_failed_presentations`` it does not move its staircase
(``counted`` false) and the same staircase is shown again, at most ``repeat_limit`` times in a
row (then the answer counts, still flagged, so a display that keeps failing cannot stall the
session).

Each staircase starts at ``start_fraction`` and moves the disc up when the glare image looked
brighter and down when the disc did, by ``step_fractions[k]`` once it has had ``k`` reversals
(the last step is kept; as in PsychoPy's ``StairHandler``, the reversing move already takes the
smaller step). The intensities are whole steps of the staircase's grid
(:func:`glarelab.protocols.staircase.intensity_grid`), so a value is written the same however it
was reached. **Neither** means the two looked equally bright, a point of equality, and
always counts as a reversal, which guarantees the staircase ends:

- ``hold``: the disc stays where it is;
- ``alternate``: the disc steps against the staircase's last direction (bracketing).

A staircase ends after ``reversals`` reversals (or 4 × reversals + 20 trials, whichever is
first). The analysis estimates the match from the reversal points.

PsychoPy's ``StairHandler`` is not used: it models two-outcome responses (correct/incorrect),
has no third answer, and importing it would put PsychoPy into this screen-free engine.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from glarelab.experiments.engine import Engine, LookingObserver, participant_rng
from glarelab.protocols.staircase import (
    Staircase,
    comparison_terms,
    flash_frames,
    glare_name,
    intensity_grid,
)

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["Staircase", "StaircaseEngine", "StaircaseObserver", "counterbalance_for"]

CONTEXT_WORDS = {  # Spencer 1995 §4: the source "by itself ... a black field", "a desk lamp"
    "uniform": "the lights alone, on a dark field",
    "lamp": "the light as the bulb of a desk lamp, on a desk",
}

PROMPT = "←  left brighter        ↓  neither        right brighter  →"

RESPONSE_KEYS = ("left", "right", "down")


def counterbalance_for(participant: str) -> int:
    """Block order of a participant from the number in their id: odd → 0 (the protocol's
    order), even → 1 (reversed), so consecutive participants alternate.

    Parameters
    ----------
    participant
        The participant's id, with a number in it (the last one counts).

    Returns
    -------
    int
        0 or 1.

    Raises
    ------
    ValueError
        For an id without a number.
    """
    digits = re.findall(r"\d+", participant)
    if not digits:
        raise ValueError(
            f"participant {participant!r} has no number to counterbalance by; "
            "give --counterbalance 0 or 1"
        )
    return 0 if int(digits[-1]) % 2 == 1 else 1


class StaircaseEngine(Engine):
    """The engine of a staircase protocol (no PsychoPy).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.
    participant
        The participant's id (it seeds the participant's orders).
    session
        The session's number, from 1; default 1.
    counterbalance
        0 (the protocol's order of the contexts) or 1 (reversed); default None: from
        the participant's id (:func:`counterbalance_for`).
    refresh_hz
        The display's refresh rate, Hz, > 0: the flash's duration in frames. Default 60.
    """

    counterbalanced = True

    def __init__(
        self,
        protocol: Protocol,
        participant: str,
        *,
        session: int = 1,
        counterbalance: int | None = None,
        refresh_hz: float = 60.0,
    ):
        if counterbalance is None:
            counterbalance = counterbalance_for(participant)
        if counterbalance not in (0, 1):
            raise ValueError(f"counterbalance must be 0 or 1; got {counterbalance!r}")
        if not refresh_hz > 0:
            raise ValueError(f"refresh_hz must be > 0; got {refresh_hz!r}")
        self.protocol = protocol
        self.study = protocol.study
        self.participant = participant
        self.session = session
        self.refresh_hz = refresh_hz
        contexts = [c["name"] for c in protocol["contexts"]]
        self.contexts = contexts if counterbalance == 0 else contexts[::-1]
        self.counterbalance = counterbalance
        self.repeat_failed = protocol["trials"]["repeat_failed_presentations"]
        self.repeat_limit = protocol["trials"]["repeat_limit"]
        self.repeats = 0  # failed flashes of the current trial shown again so far
        self.rng = participant_rng(protocol.seed, participant, f"{protocol.study} trials")
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
                grid=intensity_grid(t),
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
        self.frames = flash_frames(self.duration_ms, self.refresh_hz)
        self.presentation_ok = True

    @property
    def done(self) -> bool:
        return self.phase == "done"

    @property
    def context(self) -> str:
        return self.contexts[self.block]

    def _context_words(self) -> str:
        """What the participant sees in this block, in words (the context's background)."""
        table = next(c for c in self.protocol["contexts"] if c["name"] == self.context)
        kind = (table.get("background") or {}).get("kind", "uniform")
        return CONTEXT_WORDS.get(kind, f"the lights on a background ({kind})")

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
            return {
                "kind": "block",
                "text": f"Part {self.block + 1} of {len(self.contexts)}: "
                f"{self._context_words()}.\n\nThe task stays the same: which light looked "
                "brighter?",
                "keys": {"space": "continue"},
            }
        if self.phase == "done":
            return {"kind": "done", "keys": {}}
        s = self.current
        maximum = self.protocol["display"]["max_cd_m2"]
        glare = {"role": "glare", "terms": [(glare_name(self.context, s.level), 1.0)]}
        comparison = {
            "role": "comparison",
            "terms": comparison_terms(
                self.context, s.fraction * maximum, self.protocol["stimulus"]["annulus_ratio"]
            ),
        }
        return {
            "kind": "present",
            "trial": self.trial + 1,
            "block": self.context,
            "images": [glare, comparison] if self.glare_side == "left" else [comparison, glare],
            "glare_level": s.level,
            "glare_side": self.glare_side,
            "disc_fraction": s.fraction,
            "frames": self.frames,
            "duration_ms": self.duration_ms,
            "blank_before_ms": self.protocol["trials"]["inter_trial_ms"],
            "context": self.context,
            "prompt": PROMPT,
            "keys": {
                "left": "left looked brighter",
                "right": "right looked brighter",
                "down": "neither",
            },
        }

    def presented(self, ok: bool) -> None:
        """Whether the flash just shown kept its frames (recorded as ``presentation_ok``).

        Parameters
        ----------
        ok
            Whether the last timed presentation kept its frames.
        """
        self.presentation_ok = bool(ok)

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
        counted = presentation_ok or not self.repeat_failed or self.repeats >= self.repeat_limit
        self.repeats = 0 if counted else self.repeats + 1
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
        """Rebuild every staircase from the recorded responses, then continue.

        Parameters
        ----------
        rows
            The rows already on disk, in order, as :func:`glarelab.experiments.data.read_rows`
            reads them.
        """
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


class StaircaseObserver(LookingObserver):
    """A simulated observer of a staircase study: looks at the glare image and the comparison
    as the display shows them (:mod:`glarelab.observers`) and says which looked
    brighter, or neither, with the noise of one brief comparison and a shift of its own per block.

    Parameters
    ----------
    protocol
        A staircase protocol; its ``[observer]`` table may change the model's and the noise's
        parameters.
    participant, seed
        Who, and the simulation's seed (they fix the observer and every trial's noise).
    stimuli
        The stimulus set it looks at, or the set as displayed
        (:class:`glarelab.observers.looking.ObservedSet`, shared by observers to share
        percepts).
    """

    NOISE_KEYS = frozenset({"gain_sd", "comparison_sd", "neither_band", "block_sd"})

    @staticmethod
    def judged(protocol: Protocol | Mapping[str, Any], geometry: dict):
        """The glare at each strength over the clamp (the display's peak), the source of
        ``geometry["source_diameter_deg"]``, each context's background, the pixel size, the
        display's bit depth and the room's light
        (:meth:`glarelab.experiments.engine.LookingObserver.judged`).

        Parameters
        ----------
        protocol : glarelab.protocols.Protocol
            The study's protocol (or its data as a mapping): its ``[glare]`` table's
            ``model``, ``parameters``, ``strengths`` and ``peak_fraction``, its
            ``[display]`` table's ``max_cd_m2`` and ``black_cd_m2`` (cd/m²) and
            ``bit_depth``, its ``[viewing]`` table's ``room_lux`` (lx) and its
            ``contexts``' backgrounds.
        geometry
            The stimulus set's geometry (its manifest's ``geometry``): ``source_diameter_deg``
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
        peak = glare["peak_fraction"] * protocol["display"]["max_cd_m2"]
        backgrounds = tuple(
            judged_background(
                f"context {context['name']!r}",
                context["background"],
                disk_cd_m2=peak,
                black_cd_m2=protocol["display"]["black_cd_m2"],
            )
            for context in protocol["contexts"]
        )
        return JudgedStimuli(
            (
                JudgedGlare(
                    "glare",
                    glare["model"],
                    glare.get("parameters"),
                    tuple(1.0 + strength for strength in glare["strengths"]),
                ),
            ),
            disk_cd_m2=peak,
            disk_diameter_deg=geometry["source_diameter_deg"],
            backgrounds=backgrounds,
            pixel_deg=geometry["pixel_deg"],
            bit_depth=protocol["display"]["bit_depth"],
            room_lux=protocol["viewing"]["room_lux"],
        )

    def __init__(self, protocol: Protocol, participant: str, *, seed: int, stimuli):
        super().__init__(protocol, participant, seed=seed, stimuli=stimuli)
        g = self.display.geometry
        self.centre = tuple(g["centre_px"])
        self.pixel_deg = g["pixel_deg"]
        self.diameters = {"glare": g["source_diameter_deg"], "comparison": g["disc_diameter_deg"]}
        self._shifts: dict[str, float] = {}

    def _percept(self, image: dict):
        return self.display.percept(
            self.model,
            image["terms"],
            centre_px=self.centre,
            diameter_deg=self.diameters[image["role"]],
            pixel_deg=self.pixel_deg,
        )

    def keys(self, screen: dict) -> list[tuple[str, float]]:
        """The answer (with its time from the flash's onset) to a flash.

        Parameters
        ----------
        screen
            The engine's screen to answer. (a ``present`` flash).

        Returns
        -------
        list of tuple of (str, float)
            ``(key, seconds from the onset)`` of each press, in order.

        Raises
        ------
        ValueError
            For a screen of another kind.
        """
        if screen["kind"] != "present":
            raise ValueError(f"a staircase observer cannot answer a {screen['kind']!r} screen")
        context = screen["context"]
        if context not in self._shifts:  # the observer's own shift in this block
            self._shifts[context] = self.noise.block_shift(
                participant_rng(
                    self.protocol.seed, self.participant, f"observer {self.seed} block {context}"
                )
            )
        rng = participant_rng(
            self.protocol.seed, self.participant, f"observer {self.seed} trial {screen['trial']}"
        )
        images = {image["role"]: image for image in screen["images"]}
        seen = self.observer.compare(
            self._percept(images["glare"]),
            self._percept(images["comparison"]),
            rng,
            shift=self._shifts[context],
        )
        if seen == "neither":
            key = "down"
        elif seen == "first":
            key = screen["glare_side"]
        else:
            key = "left" if screen["glare_side"] == "right" else "right"
        return [(key, 0.6 + float(rng.exponential(0.4)))]
