"""A session's key presses and typed comments.

One :class:`glarelab.frontend.window.KeyReader` for the session, never cleared after the first
screen. Psychtoolbox names keys by their position on a US keyboard on Linux and macOS (a French
keyboard's unshifted ``&`` key is ``1``), so a rating is its key's digit in any layout; the
keypad's digits count too. Comments are read from the window system's text events (the
keyboard's layout, case, punctuation and accents as typed, Backspace and the arrows as editing):
what was typed after the rating key's own character and before the Enter that ends the comment,
even before the comment box appeared; Shift+Enter is a new line in it.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from glarelab.frontend.window import (
    KeyReader,
    TextCapture,
    dispatch_events,
    key_symbols,
    typed_text,
)

__all__ = [
    "ScriptedKeys",
    "SessionKeys",
    "comment_start",
    "past_held_key",
    "scripted_text_event",
    "unknown_key_names",
]


def unknown_key_names(names: list[str]) -> list[str]:
    """The names in ``names`` that PsychoPy gives no key on any system (sorted, once each):
    a typo in a dry run's scripted keys would be an ignored press.

    Parameters
    ----------
    names
        Key names as PsychoPy's keyboard reports them (``"space"``, ``"left"``, ...).

    Returns
    -------
    list of str
        The unknown names, sorted, once each; empty when all are known.
    """
    from psychopy.hardware.keyboard import keyNamesLinux, keyNamesMac, keyNamesWin

    known = set(keyNamesLinux.values()) | set(keyNamesMac.values()) | set(keyNamesWin.values())
    return sorted({name for name in names if name not in known})


# a scripted key's text event in a comment's box: what typing the key (unshifted, US layout)
# sends the window; other keys (shift, f1, ...) type nothing
SCRIPTED_TEXT = {"space": " ", "return": "\r", "num_enter": "\r", "comma": ",", "period": ".",
                 "minus": "-", "apostrophe": "'", "semicolon": ";", "slash": "/"}  # fmt: skip
SCRIPTED_MOTION = {"backspace": "MOTION_BACKSPACE", "delete": "MOTION_DELETE",
                   "left": "MOTION_LEFT", "right": "MOTION_RIGHT",
                   "home": "MOTION_BEGINNING_OF_LINE", "end": "MOTION_END_OF_LINE"}  # fmt: skip


def scripted_text_event(name: str) -> tuple[str, str] | None:
    """The text event (:func:`glarelab.frontend.window.typed_text`) a scripted key makes in a
    comment's box: a letter or digit itself, ``space`` a space, ``return`` the Enter that ends
    the comment, ``backspace`` and the arrows their motions; None for a key that types nothing.

    Parameters
    ----------
    name
        A PsychoPy key name (``--scripted-keys``).

    Returns
    -------
    tuple of (str, str) or None
        ``("text", characters)``, ``("motion", name)`` or None.

    Examples
    --------
    >>> [scripted_text_event(n) for n in ("g", "space", "backspace", "lshift")]
    [('text', 'g'), ('text', ' '), ('motion', 'MOTION_BACKSPACE'), None]
    """
    if len(name) == 1 and name.isprintable():
        return ("text", name)
    if name.startswith("num_") and len(name) == 5 and name[-1].isdigit():
        return ("text", name[-1])
    if name in SCRIPTED_TEXT:
        return ("text", SCRIPTED_TEXT[name])
    if name in SCRIPTED_MOTION:
        return ("motion", SCRIPTED_MOTION[name])
    return None


_ENTER = (("text", "\r"), ("repeat", "\r"))  # the comment's end (typed_text's)


def comment_start(events: list[tuple[str, str]], mark: int, symbols: set[str], rating: str) -> int:
    """Where a comment begins in a window's text events (:class:`TextCapture`): after the
    rating key's press from ``mark`` on, its own character, and that character auto-repeated
    while the key stayed down (a rating key held for a second typed '555555555' into the
    comment); characters typed before the box showed are kept.

    Parameters
    ----------
    events
        The window's text events.
    mark
        The first event of the rating screen.
    symbols
        The rating key's symbols in the keyboard's layout (:func:`key_symbols`), as text.
    rating
        The rating, as its key's name (``'5'``): found by its text where no key event is.

    Returns
    -------
    int
        The index of the comment's first event.

    Examples
    --------
    >>> held = [("key", "53"), ("text", "5"), ("repeat", "5"), ("repeat", "5"), ("key", "104"),
    ...         ("text", "h"), ("repeat", "h")]
    >>> typed_text(held, comment_start(held, 0, {"53"}, "5"))[0]
    'hh'
    """
    start = None
    for index in range(mark, len(events)):
        if events[index][0] == "key" and events[index][1] in symbols:
            start = index + 1
            if start < len(events) and events[start][0] == "text":
                start += 1  # the rating key's own character
            break
    else:
        for index in range(mark, len(events)):  # no key events: by its text
            if events[index] == ("text", rating):
                start = index + 1
                break
    if start is None:
        return len(events)
    return past_held_key(events, start)  # the rating key held down


def past_held_key(events: list[tuple[str, str]], start: int) -> int:
    """``start`` moved past the auto-repeats of the character just before it that arrived
    since (:func:`comment_start` found those already there: the rating key may still be held
    when the comment's box shows).

    Parameters
    ----------
    events
        The window's text events.
    start
        A comment's first event (:func:`comment_start`).

    Returns
    -------
    int
        The index of the first event that is not the held key's repeat.

    Examples
    --------
    >>> events = [("key", "53"), ("text", "5")]
    >>> start = comment_start(events, 0, {"53"}, "5")
    >>> events += [("repeat", "5"), ("repeat", "5"), ("key", "111"), ("text", "o")]
    >>> typed_text(events, past_held_key(events, start))[0]
    'o'
    """
    own = next((v for k, v in reversed(events[:start]) if k in ("text", "repeat")), None)
    while start < len(events) and events[start] == ("repeat", own):
        start += 1
    return start


class ScriptedKeys:
    """Key names read from a list instead of the keyboard (dry runs): one press per read, at
    the time it is read; ``escape`` when the list is used up.

    Parameters
    ----------
    names
        The key names, in the order they are pressed (``--scripted-keys``).
    """

    def __init__(self, names: list[str]):
        self.names = list(names)

    def read(self) -> list[tuple[str, float]]:
        from psychopy import logging

        name = self.names.pop(0) if self.names else "escape"
        return [(name, logging.defaultClock.getTime())]

    def clear(self) -> None:
        pass


class SessionKeys:
    """The presses and the typing of a session's window.

    Parameters
    ----------
    window
        The open PsychoPy window.
    scripted
        Key names to use instead of the keyboard (dry runs), consumed in order; None: the
        keyboard.
    log
        Where a line of the session's log goes.
    """

    def __init__(self, window, scripted: list[str] | None, *, log: Callable[[str], None]):
        self.window = window
        self.scripted = scripted
        self.reader = ScriptedKeys(scripted) if scripted is not None else KeyReader()
        self.typing = TextCapture(window)
        self._log = log
        self._returns_seen = 0  # Enter presses Psychtoolbox reported (see without_shift_enter)
        self._typing_mark = 0  # where the current screen's typing began
        self._comment_start: int | None = None
        self.held: list[tuple[str, float]] = []  # presses read during a presentation

    def start(self) -> None:
        """From now on every key press counts: Enter pressed before now is not counted by
        either reader."""
        self.reader.clear()
        dispatch_events(self.window)
        self._returns_seen = len(self.typing.returns)

    def showing(self, screen: dict) -> None:
        """A screen is shown: a comment's box starts its comment, any other screen its own
        typing.

        Parameters
        ----------
        screen
            The screen now shown; ``text_entry`` marks a comment's box.
        """
        if screen.get("text_entry") and self._comment_start is None:
            self._start_comment(screen)
        elif not screen.get("text_entry"):
            self._typing_mark = max(self._typing_mark, len(self.typing.events))

    def read(self, *, text_entry: bool) -> list[tuple[str, float]]:
        """New presses; on a text-entry screen without those of Shift+Enter.

        Parameters
        ----------
        text_entry
            Whether the screen shown takes typed text.

        Returns
        -------
        list of tuple of (str, float)
            ``(key name, time)`` of each new press, s on the session clock.
        """
        presses = self.reader.read()
        if self.scripted is not None and text_entry:  # a dry run types as the keyboard would
            for name, _ in presses:
                event = scripted_text_event(name)
                if event is not None:
                    self.typing.events.append(event)
        if self.scripted is not None or not any(
            name in ("return", "num_enter") for name, _ in presses
        ):
            return presses
        kept = self._without_shift_enter(presses)
        return kept if text_entry else presses

    def _without_shift_enter(self, presses: list[tuple[str, float]]) -> list:
        """A comment's presses without an Enter pressed with Shift: that is a new line in the
        comment (its text event), not its end. Psychtoolbox does not report modifiers, so the
        n-th Enter it reports is the window system's n-th Enter key event, whose modifiers
        say."""
        if self.scripted is not None:
            return presses
        kept = []
        for name, t in presses:
            if name not in ("return", "num_enter"):
                kept.append((name, t))
                continue
            index = self._returns_seen
            self._returns_seen += 1
            deadline = time.monotonic() + 0.2
            while len(self.typing.returns) <= index and time.monotonic() < deadline:
                dispatch_events(self.window)  # its key event, a moment behind Psychtoolbox's
                time.sleep(0.001)
            if index < len(self.typing.returns) and self.typing.returns[index]:
                self._log(f"key {name} with shift at {t:.4f}: a new line in the comment")
            else:
                kept.append((name, t))
        return kept

    def _start_comment(self, screen: dict) -> None:
        """Where the comment begins: after the rating key's press and its own character (in
        the keyboard's layout: ``(`` for the 5 of a French keyboard), typed since the rating
        screen appeared; characters typed before the box showed are kept."""
        dispatch_events(self.window)
        rating = str(screen.get("rating", ""))
        symbols = {str(s) for s in key_symbols(self.window, (rating, f"num_{rating}"))}
        self._comment_start = comment_start(self.typing.events, self._typing_mark, symbols, rating)

    def comment_so_far(self) -> tuple[str, int]:
        """The comment typed so far and the cursor's place in it (for its box)."""
        events = self.typing.events
        text, cursor, _ = typed_text(events, past_held_key(events, self._comment_start or 0))
        return text, cursor

    def typed(self) -> str:
        """The comment typed since the comment screen's rating key, up to its Enter."""
        dispatch_events(self.window)  # the characters typed before Enter
        start = self._comment_start if self._comment_start is not None else len(self.typing.events)
        start = past_held_key(self.typing.events, start)
        text, _, _ = typed_text(self.typing.events, start)
        end = start
        while end < len(self.typing.events) and self.typing.events[end] not in _ENTER:
            end += 1
        self._typing_mark = min(end + 1, len(self.typing.events))  # the next screen's typing
        self._comment_start = None
        return text
