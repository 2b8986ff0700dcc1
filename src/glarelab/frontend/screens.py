"""The text of a session's screens: instructions, labels under the images, the marker of the
selected target, the answer prompt, the comment box, and a pilot's PILOT mark.

Letter keys are named as the keyboard layout labels them: a screen that takes the key
PsychoPy calls ``y`` (its position on a US keyboard) says "Z = yes" on a German layout, where
that key is labelled Z (:func:`glarelab.frontend.window.key_labels`), in its text ("Y = …")
and in the key legend ("Y / N").

The comment box grows down with what is typed, to the bottom of the window; a longer comment
scrolls (its beginning leaves the box, "…" in its place, the cursor always in view). The
comment is kept whole whatever the box shows."""

from __future__ import annotations

import re

__all__ = ["PAUSE_KINDS", "ScreenText"]

TEXT_RGB = (0.5, 0.5, 0.5)  # instructions and prompts: a mid grey on black
DIM_RGB = (-0.4, -0.4, -0.4)  # labels next to the stimuli: dim, to leave the judgement alone
MARKER_RGB = (0.2, 0.2, 0.2)  # the bar under the selected target
PAUSE_KINDS = ("instructions", "block", "break", "continue", "end")
BOX_TOP_PX = 40  # the comment box's top edge, above the window's middle
BOX_MIN_HEIGHT_PX = 160
BOX_MARGIN_PX = 20  # between the box and the window's bottom edge, and inside the box


class ScreenText:
    """The text stimuli of a session's window, made once when it opens.

    Parameters
    ----------
    window
        The open PsychoPy window.
    pilot
        A pilot run: "PILOT" in the window's top-left corner on every frame.
    """

    def __init__(self, window, *, pilot: bool):
        from psychopy import visual

        self.window = window
        self.text = visual.TextStim(
            window,
            text="",
            height=22,
            wrapWidth=1100,
            color=TEXT_RGB,
            colorSpace="rgb",
            autoLog=False,
        )
        self.label = visual.TextStim(
            window, text="", height=16, color=DIM_RGB, colorSpace="rgb", autoLog=False
        )
        self.marker = visual.Rect(
            window,
            width=10,
            height=6,
            units="pix",
            fillColor=MARKER_RGB,
            lineColor=None,
            colorSpace="rgb",
            autoLog=False,
        )
        self.pilot_mark = None
        if pilot:  # drawn on every flip: no screen of a pilot passes for a session's
            width, height = window.size
            self.pilot_mark = visual.TextStim(
                window,
                text="PILOT",
                height=20,
                pos=(-width / 2 + 12, height / 2 - 10),
                anchorHoriz="left",
                anchorVert="top",
                alignText="left",
                color=(0.6, -0.6, -0.6),
                colorSpace="rgb",
                autoLog=False,
            )
            self.pilot_mark.autoDraw = True
        self._comment_shown: str | None = None
        self._known: dict[str, str] = {}  # letter keys' labels in the layout
        self.box = visual.Rect(
            window,
            width=900,
            height=BOX_MIN_HEIGHT_PX,
            pos=(0, BOX_TOP_PX - BOX_MIN_HEIGHT_PX / 2),
            units="pix",
            fillColor=None,
            lineColor=DIM_RGB,
            colorSpace="rgb",
            autoLog=False,
        )
        self.typed_stim = visual.TextStim(
            window,
            text="",
            height=24,
            wrapWidth=880,
            pos=(-440, 30),
            anchorHoriz="left",
            anchorVert="top",
            alignText="left",
            color=TEXT_RGB,
            colorSpace="rgb",
            autoLog=False,
        )

    def draw_text(self, text: str, *, pos=(0, 0), below: bool = False) -> None:
        """``text`` centred at ``pos`` (pixels from the centre); with ``below``, its first line
        at ``pos`` and the rest under it (a prompt under the images).

        Parameters
        ----------
        text
            The text.
        pos
            ``(x, y)`` of its anchor, pixels from the window's centre; default the centre.
        below
            Whether the text hangs below ``pos`` instead of centring on it; default False.
        """
        self.text.text = text
        self.text.anchorVert = "top" if below else "center"
        self.text.pos = pos
        self.text.draw()

    def draw(
        self,
        screen: dict,
        stims: list,
        *,
        prompt: bool = True,
        comment: tuple[str, int] | None = None,
    ) -> None:
        """The screen's text around its placed image ``stims`` (drawn before): labels and
        marker under them; the screen's text, or its answer prompt; the box of a typed answer
        with ``comment`` (its text and the cursor's place).

        Parameters
        ----------
        screen
            The engine's screen: its images' roles and ``labels``, ``marker``, ``text`` and
            prompt.
        stims
            The screen's image stimuli, already placed and drawn.
        prompt
            Whether to draw the answer prompt (a flash's prompt comes after it); default True.
        comment
            ``(text, cursor)`` of a typed answer, to draw in its box; default None: no box.
        """
        roles = [image["role"] for image in screen.get("images", [])]
        bottom = -max((s.size[1] for s in stims), default=0) / 2
        for role, stim in zip(roles, stims, strict=True):
            label = screen.get("labels", {}).get(role)
            if label:
                self.label.text = label
                self.label.pos = (stim.pos[0], bottom - 36)
                self.label.draw()
            if screen.get("marker") == role:
                self.marker.width, self.marker.pos = stim.size[0], (stim.pos[0], bottom - 14)
                self.marker.draw()
        text = self._as_labelled(screen.get("text", "").strip(), screen.get("keys", {}))
        if screen["kind"] in PAUSE_KINDS:
            legend = screen.get("legend")
            if legend:
                lines = [
                    f"{self._legend_keys(keys)}: {what}" if keys else what for keys, what in legend
                ]
                text += "\n\nKeys\n" + "\n".join(lines) + "\nEsc: end the session"
            if "space" in screen.get("keys", {}):
                text += "\n\nPress SPACE to continue."
        if text:
            self.draw_text(text, pos=(0, 120) if screen.get("text_entry") else (0, 0))
        if prompt and screen.get("prompt"):
            shown = self._as_labelled(screen["prompt"], screen.get("keys", {}))
            self.draw_text(shown, pos=(0, bottom - 56), below=True)
        if screen.get("text_entry"):
            typed, cursor = comment or ("", 0)
            self._lay_out_comment(typed[:cursor] + "|" + typed[cursor:], cursor)
            self.box.draw()
            self.typed_stim.draw()

    def _labels(self, names) -> dict[str, str]:
        """The layout's labels of letter keys, looked up once each."""
        wanted = [n for n in names if len(n) == 1 and n.isalpha() and n not in self._known]
        if wanted:
            from glarelab.frontend.window import key_labels

            self._known |= key_labels(self.window, wanted)
        return {n: self._known[n] for n in names if n in self._known}

    def _as_labelled(self, text: str, keys) -> str:
        """``text`` with each letter key of ``keys`` named as "Y = …" written with its label."""
        for name, label in self._labels(list(keys)).items():
            if label != name.upper():
                text = re.sub(rf"(?<!\w){name.upper()}(?= = )", label, text)
        return text

    def _legend_keys(self, keys: str) -> str:
        """A legend's keys ("Y / N") with the letters named by their labels."""
        tokens = keys.split(" / ")
        labels = self._labels([t.lower() for t in tokens if len(t) == 1 and t.isalpha()])
        return " / ".join(labels.get(t.lower(), t) for t in tokens)

    def _lay_out_comment(self, shown: str, cursor: int) -> None:
        """Fit the box to the comment (``shown``, the cursor drawn at ``cursor``): taller as it
        grows, down to the window's bottom; beyond that its beginning scrolls out of view."""
        if shown == self._comment_shown:  # laid out already (the box is redrawn every frame)
            return
        self._comment_shown = shown
        room = self.window.size[1] / 2 + BOX_TOP_PX - BOX_MARGIN_PX  # to the bottom edge
        stim = self.typed_stim

        def height(text: str) -> float:
            stim.text = text
            return float(stim.boundingBox[1]) + 2 * BOX_MARGIN_PX

        if height(shown) > room:  # the fewest characters left out that let the rest fit
            low, high = 1, cursor  # the cursor stays in view
            while low < high:
                middle = (low + high) // 2
                if height("…" + shown[middle:]) > room:
                    low = middle + 1
                else:
                    high = middle
            height("…" + shown[low:])
        box = min(max(float(stim.boundingBox[1]) + 2 * BOX_MARGIN_PX, BOX_MIN_HEIGHT_PX), room)
        self.box.height = box
        self.box.pos = (0, BOX_TOP_PX - box / 2)
