"""The PsychoPy window and keyboard of every glarelab screen: photometer sessions, experiment
sessions and the display check. Only the front-end modules import this one, and it imports
PsychoPy only when called.

- :func:`open_window` asks for the bits per channel the display needs (10 on a 10-bit display)
  and reports the bits the window was given; it never silently runs at fewer.
- :func:`measure_refresh` measures the frame interval on the open window (PsychoPy's
  ``getActualFrameRate``) and returns None when no stable interval was found: a failed
  measurement is never taken for a nominal rate.
- :class:`KeyReader` is one ``psychopy.hardware.keyboard.Keyboard`` (Psychtoolbox backend,
  key-down times stamped by the operating system's input thread) whose presses are each
  returned once, in the order pressed, and never cleared: a key pressed while a screen redraws,
  or during a flash, is kept.
- :class:`TextCapture` keeps every character the window system types into the window (its
  text events: the keyboard's layout, case, punctuation and accents as typed), in order, and
  :func:`typed_text` turns a stretch of them into the text they type.
- :func:`compose_typed_text`: accents typed with dead keys (French ``^`` then ``e`` for ê,
  German ``´`` then ``e`` for é) and Compose sequences reach the text events composed, by the X
  input method, windowed and full screen (:func:`open_window` calls it).
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys

import numpy as np

__all__ = [
    "KeyReader",
    "TextCapture",
    "compose_typed_text",
    "grab_screen",
    "held_keys_press_once",
    "key_labels",
    "key_symbols",
    "measure_frame_intervals",
    "measure_refresh",
    "on_display_lost",
    "open_window",
    "read_framebuffer_codes",
    "screen_resolution",
    "typed_text",
    "window_bits",
]

BACKGROUND = (-1.0, -1.0, -1.0)  # black, in PsychoPy's rgb (-1 .. 1)


def open_window(
    *,
    bits: int,
    fullscreen: bool,
    size: tuple[int, int] = (1280, 800),
    units: str = "pix",
    screen: int = 0,
    monitor=None,
):
    """A PsychoPy window asking for ``bits`` per channel (10 or more: a deep frame buffer),
    opened with ``monitor`` (a ``psychopy.monitors.Monitor``; default one that describes no
    geometry, :func:`glarelab.frontend.monitors.window_monitor`): PsychoPy then has a monitor,
    does not warn "Monitor specification not found", and keeps the graphics card's gamma table.

    Parameters
    ----------
    bits
        Bits per channel asked for, from 8.
    fullscreen
        Whether the window fills the screen.
    size
        The window's size in pixels when not full-screen; default ``(1280, 800)``.
    units
        PsychoPy's units of the window; default ``'pix'``.
    screen
        The screen's number; default 0.
    monitor : psychopy.monitors.Monitor, optional
        The monitor the window is opened with, as
        :func:`~glarelab.frontend.monitors.window_monitor` makes it (its size, width and
        viewing distance; its gamma grid the default, so the card's gamma table is kept);
        None (default): ``window_monitor(None, None)``, no geometry.

    Returns
    -------
    (window, bits_given)
    """
    from psychopy import visual

    from glarelab.frontend.monitors import window_monitor

    common = dict(
        monitor=monitor if monitor is not None else window_monitor(None, None),
        size=size,
        fullscr=fullscreen,
        screen=screen,
        units=units,
        color=BACKGROUND,
        colorSpace="rgb",
        allowGUI=False,
        useFBO=False,
        checkTiming=False,
        waitBlanking=True,
    )
    window = None
    if bits > 8:
        try:
            window = visual.Window(bpc=(bits, bits, bits), **common)
        except RuntimeError:  # no deep frame buffer on this screen: an 8-bit one
            window = None
    if window is None:
        window = visual.Window(**common)
    window.mouseVisible = False
    compose_typed_text(window)
    held_keys_press_once(window)
    return window, window_bits()


def on_display_lost(window, ended) -> bool:
    """Have the loss of ``window``'s X display (the server killed, a remote session closed)
    end the process as a stop does: ``ended()`` records the end, then exit status 3. Xlib's
    default ends the process at once, or pyglet's clean-up then crashed it (exit 139), with the
    session's sidecar still 'running'.

    Parameters
    ----------
    window
        The open PsychoPy window.
    ended
        Called once the display is gone (it must not draw): writes what the session's end
        says; its own failure is ignored, the process ends either way.

    Returns
    -------
    bool
        Whether the handler was set (only pyglet's X11 windows have one).

    Notes
    -----
    Xlib calls the handler of a lost connection and ends the process when it returns, so it
    never returns: it calls ``ended`` and ends the process with ``os._exit(3)`` (no clean-up
    that would speak to the lost display).
    """
    handle = getattr(window, "winHandle", None)
    if not (sys.platform.startswith("linux") and getattr(handle, "display", None)):
        return False
    import threading

    from pyglet.libs.x11 import xlib

    once = threading.Lock()  # each connection (and thread) reports the loss: one ends it

    def lost(_display) -> int:
        once.acquire()  # never released: a second caller waits for the exit
        with contextlib.suppress(BaseException):
            sys.stderr.write(
                "[glarelab] the X display was lost (its server ended or the session was "
                "closed): the session ends as aborted, every finished trial kept\n"
            )
            ended()
        os._exit(3)

    handler = xlib.XIOErrorHandler(lost)
    window.glarelab_display_lost = handler  # kept alive as long as the window
    xlib.XSetIOErrorHandler(handler)
    return True


def held_keys_press_once(window) -> bool:
    """Ask the X server to send a key held down as one press and repeated text (XKB's
    detectable auto-repeat) on ``window``'s connection; whether it was set (only pyglet's X11
    windows need it).

    pyglet asks it only for the first connection it opens, and PsychoPy's window has another:
    there a held key came as a release and a new press 25 times a second, so its repeated
    characters could not be told from keys pressed again (a rating key held for a second typed
    '555555555' into the comment that followed). :class:`TextCapture` then records them as
    ``("repeat", text)``.

    Parameters
    ----------
    window
        The open PsychoPy window.

    Returns
    -------
    bool
        Whether the server now reports held keys so.
    """
    handle = getattr(window, "winHandle", None)
    display = getattr(getattr(handle, "display", None), "_display", None)
    if not (sys.platform.startswith("linux") and display):
        return False
    from pyglet.window import xlib as pyglet_xlib

    supported = ctypes.c_int()
    done = bool(
        pyglet_xlib.XkbSetDetectableAutoRepeat(display, ctypes.c_int(1), ctypes.byref(supported))
    )
    if done and getattr(handle, "pressed_keys", None) is None:
        handle.pressed_keys = set()  # where pyglet keeps the keys down, to press them once
    return done


def compose_typed_text(window) -> bool:
    """Let the X input method compose what is typed into ``window`` (dead keys, Compose
    sequences); whether it was set up (only pyglet's X11 windows need it).

    pyglet (1.5) creates the window's input context for its top-level window but receives key
    events in a child window (its view), so the input method never sees them: a dead key then
    types nothing and the letter after it comes without its accent (``^`` ``e`` gives ``e``).
    The input context's focus window is set to the view, where the key events arrive; the X
    input method then composes them as in any X program (Xlib's Compose tables of the locale).

    Parameters
    ----------
    window
        The open PsychoPy window.

    Returns
    -------
    bool
        Whether the input context was set up.
    """
    handle = getattr(window, "winHandle", None)
    context, view = getattr(handle, "_x_ic", None), getattr(handle, "_view", None)
    if not (sys.platform.startswith("linux") and context and view):
        return False
    from pyglet.libs.x11 import xlib

    set_values = xlib.XSetICValues  # variadic: name, value, …, NULL
    set_values.argtypes = [xlib.XIC, ctypes.c_char_p, xlib.Window, ctypes.c_void_p]
    set_values.restype = ctypes.c_char_p  # the first name not set, or NULL
    return set_values(context, b"focusWindow", view, None) is None


def window_bits() -> int:
    """Bits per channel of the current OpenGL frame buffer."""
    from pyglet import gl

    value = ctypes.c_int()
    gl.glGetIntegerv(gl.GL_RED_BITS, ctypes.byref(value))
    return int(value.value) or 8


def screen_resolution(window) -> tuple[int, int]:
    """The (width, height) in pixels of the screen the window is on.

    Parameters
    ----------
    window
        The open PsychoPy window.

    Returns
    -------
    tuple of int
        ``(width, height)``, pixels.
    """
    screen = window.winHandle.screen
    return int(screen.width), int(screen.height)


def measure_refresh(window) -> float | None:
    """The refresh rate (Hz) from frame intervals on the open window, or None when the
    intervals never settled (no vertical sync, a busy machine).

    Parameters
    ----------
    window
        The open PsychoPy window.

    Returns
    -------
    float or None
        Hz, or None.
    """
    rate = window.getActualFrameRate(nIdentical=20, nMaxFrames=240, nWarmUpFrames=20)
    return float(rate) if rate else None


def measure_frame_intervals(window, frames: int = 300, draw=None) -> np.ndarray:
    """Intervals (s) between ``frames`` consecutive flips, each after ``draw()`` if given.

    Parameters
    ----------
    window
        The open PsychoPy window.
    frames
        The intervals to measure; default 300.
    draw
        Called before each flip; default None: nothing drawn.

    Returns
    -------
    numpy.ndarray
        ``(frames,)`` intervals, s.
    """
    times = []
    for _ in range(frames + 1):
        if draw is not None:
            draw()
        times.append(window.flip())
    return np.diff(np.asarray(times, dtype=float))


def grab_screen(window, *, buffer: str = "back") -> np.ndarray:
    """The window's pixels (height, width, 3) as uint8, from the back or front buffer.

    Parameters
    ----------
    window
        The open PsychoPy window.
    buffer
        ``'back'`` (default) or ``'front'``.

    Returns
    -------
    numpy.ndarray
        uint8 ``(height, width, 3)``.
    """
    return np.asarray(window.getMovieFrame(buffer=buffer))


def read_framebuffer_codes(
    window, box: tuple[int, int, int, int], *, bits: int, buffer: str = "back"
) -> np.ndarray:
    """The codes of the window's pixels in ``box`` at ``bits`` per channel: (height, width, 3)
    integers, top row first.

    ``box`` is (left, bottom, width, height) in frame-buffer pixels from the lower-left corner
    (OpenGL's). The pixels are read at 16 bits per channel (``glReadPixels`` with
    ``GL_UNSIGNED_SHORT``), the one read that holds an 8-, 10- or 12-bit frame buffer without
    loss, and turned back into codes: ``round(value × (2^bits − 1) / 65535)``; a ``bits``-bit
    code ``c`` reads as ``round(c × 65535 / (2^bits − 1))``, within half a 16-bit step, so it
    comes back exactly.

    Parameters
    ----------
    window
        The open PsychoPy window.
    box
        ``(left, bottom, width, height)``, frame-buffer pixels from the lower-left corner.
    bits
        The codes' bits per channel, 1-16.
    buffer
        ``'back'`` (default) or ``'front'``.

    Returns
    -------
    numpy.ndarray
        Integer codes ``(height, width, 3)``, top row first.
    """
    from pyglet import gl

    left, bottom, width, height = (int(v) for v in box)
    if not 1 <= bits <= 16:
        raise ValueError(f"bits must be 1-16; got {bits!r}")
    if width < 1 or height < 1:
        raise ValueError(f"box must have a width and a height of at least 1 pixel; got {box!r}")
    if buffer not in ("back", "front"):
        raise ValueError(f"buffer must be 'back' or 'front'; got {buffer!r}")
    values = (ctypes.c_ushort * (width * height * 3))()
    gl.glReadBuffer({"back": gl.GL_BACK, "front": gl.GL_FRONT}[buffer])
    gl.glPixelStorei(gl.GL_PACK_ALIGNMENT, 1)
    gl.glReadPixels(left, bottom, width, height, gl.GL_RGB, gl.GL_UNSIGNED_SHORT, values)
    pixels = np.frombuffer(values, dtype=np.uint16).reshape(height, width, 3)[::-1]
    return np.rint(pixels * ((2**bits - 1) / 65535.0)).astype(np.int64)


class KeyReader:
    """Every key press of a session, each returned once, in the order pressed.

    Wraps one ``psychopy.hardware.keyboard.Keyboard`` on the Psychtoolbox backend. PsychoPy's
    ``getKeys`` returns a press either while the key is down (``waitRelease=False``) or after
    its release (``waitRelease=True``), never both ways at once, so a press that goes down and
    up between two reads would be missed by the first and a held key delayed by the second.
    :meth:`read` asks both ways and returns each press once, as soon as it went down.

    Times are key-down times on PsychoPy's clock (``psychopy.logging.defaultClock``, the clock
    ``window.flip()`` returns), stamped by the input thread, not when they were read.

    Raises
    ------
    RuntimeError
        If Psychtoolbox's keyboard is not available (on Linux it needs the JACK library,
        Debian's ``libjack-jackd2-0``).
    """

    def __init__(self):
        from psychopy.hardware import keyboard

        if not keyboard.havePTB:
            raise RuntimeError(
                "PsychoPy's keyboard needs Psychtoolbox (the psychtoolbox package; on Linux "
                "also the JACK library, e.g. apt install libjack-jackd2-0): without it key "
                "presses are time-stamped only when read, and some are lost"
            )
        self.keyboard = keyboard.Keyboard(backend="ptb")
        if self.keyboard.getBackend() != "ptb":
            raise RuntimeError(
                f"PsychoPy's keyboard runs on its {self.keyboard.getBackend()!r} backend, "
                "not Psychtoolbox's (another part of the program chose it first)"
            )
        self._down: list = []  # presses returned while down, until they come back released

    def read(self) -> list[tuple[str, float]]:
        """``(key name, key-down time)`` of every press not returned before, in order."""
        down = self.keyboard.getKeys(waitRelease=False, clear=True)
        released = self.keyboard.getKeys(waitRelease=True, clear=True)
        new, still_down = list(down), list(down)
        for press in released:
            if any(press is seen for seen in self._down):  # returned while down before
                self._down = [seen for seen in self._down if seen is not press]
            elif any(press is seen for seen in still_down):  # went down and up since
                still_down = [seen for seen in still_down if seen is not press]
            else:
                new.append(press)
        self._down += still_down
        new.sort(key=lambda press: press.tDown)
        return [(str(press.name), float(press.tDown)) for press in new]

    def clear(self) -> None:
        """Forget presses made so far (only before the first screen of a session)."""
        self.keyboard.clearEvents()
        self._down = []


class TextCapture:
    """Every text event of a window, in order: ``("text", characters)`` and
    ``("motion", name)`` (Backspace, Delete, arrows, Home, End), as pyglet reports them, each
    after ``("key", symbol)`` of the key press that made it (pyglet's symbols are X keysyms);
    the characters of a key held down, auto-repeated with no press of their own, as
    ``("repeat", characters)``.
    Shift+Enter types a new line (``"\\n"``); ``returns`` says of each Enter pressed
    whether Shift was down.

    PsychoPy's own handlers keep running; this one only listens.

    Parameters
    ----------
    window
        The open PsychoPy window (pyglet) whose events are captured from now on.
    """

    def __init__(self, window):
        self.events: list[tuple[str, str]] = []
        self.returns: list[bool] = []  # each Enter pressed: whether with Shift
        self._shift_return = False
        self._pressed = False  # a key press since the last text event
        window.winHandle.push_handlers(
            on_text=self._on_text, on_text_motion=self._on_motion, on_key_press=self._on_key
        )

    def _on_text(self, text: str) -> None:
        if text == "\r" and self._shift_return:  # Shift+Enter: a new line, not the end
            text = "\n"
        self._shift_return = False
        if text != "\t":  # a tab comes as its key (PsychoPy takes the text event for itself)
            # a text event with no key press of its own is the window system's auto-repeat of
            # a key held down (pyglet reports its press once)
            self.events.append(("text" if self._pressed else "repeat", text))
        self._pressed = False

    def _on_key(self, symbol: int, modifiers: int) -> None:
        from pyglet.window import key

        self.events.append(("key", str(symbol)))  # which key made the text that follows
        self._pressed = True
        self._shift_return = symbol in (key.RETURN, key.ENTER) and bool(modifiers & key.MOD_SHIFT)
        if symbol in (key.RETURN, key.ENTER):
            self.returns.append(self._shift_return)
        if symbol == key.TAB:
            self.events.append(("text", "\t"))

    def _on_motion(self, motion: int) -> None:
        from pyglet.window import key

        self.events.append(("motion", key.motion_string(motion)))


def typed_text(events: list[tuple[str, str]], start: int = 0) -> tuple[str, int, bool]:
    r"""The text typed by ``events[start:]`` up to the first Enter (``"\r"``).

    Returns the text, the cursor's position in it, and whether an Enter ended it. Backspace and
    Delete remove a character, the arrows, Home and End move the cursor; every other character
    (tabs included) is kept as typed.

    Parameters
    ----------
    events
        The window's text events (:class:`TextCapture`): ``("text", characters)`` and
        ``("motion", name)``.
    start
        The first event of the text; default 0.

    Examples
    --------
    >>> keys = [("text", "T"), ("text", "o"), ("text", "o"), ("motion", "MOTION_BACKSPACE"),
    ...         ("text", "o,"), ("motion", "MOTION_LEFT"), ("text", "!"), ("text", "\r"),
    ...         ("text", "7")]
    >>> typed_text(keys)
    ('Too!,', 4, True)
    """
    text: list[str] = []
    cursor = 0
    for kind, value in events[start:]:
        if kind in ("text", "repeat"):  # a held key types its character again
            if value == "\r":  # Enter (Shift+Enter comes as a new line, "\n")
                return "".join(text), cursor, True
            text[cursor:cursor] = list(value)
            cursor += len(value)
        elif value == "MOTION_BACKSPACE" and cursor > 0:
            del text[cursor - 1]
            cursor -= 1
        elif value == "MOTION_DELETE" and cursor < len(text):
            del text[cursor]
        elif value == "MOTION_LEFT":
            cursor = max(cursor - 1, 0)
        elif value == "MOTION_RIGHT":
            cursor = min(cursor + 1, len(text))
        elif value in ("MOTION_BEGINNING_OF_LINE", "MOTION_BEGINNING_OF_FILE"):
            cursor = 0
        elif value in ("MOTION_END_OF_LINE", "MOTION_END_OF_FILE"):
            cursor = len(text)
    return "".join(text), cursor, False


def key_symbols(window, names) -> set[int]:
    """The pyglet symbols (X keysyms) that the keys PsychoPy's keyboard calls ``names`` make
    in the keyboard layout now in use, at every shift level: on a French AZERTY layout the key
    named ``5`` makes ``parenleft`` unshifted and ``5`` shifted.

    Psychtoolbox names a key by its position (on Linux its X key code + 1, by
    ``psychopy.hardware.keyboard.keyNamesLinux``), whatever the layout; the window system's text
    events follow the layout. Elsewhere than on X11 only the symbols of the names' own
    characters are given (a digit's key and its keypad key).

    Parameters
    ----------
    window
        The open PsychoPy window.
    names
        Key names as PsychoPy's keyboard gives them.

    Returns
    -------
    set of int
        The symbols.
    """
    from pyglet.window import key

    symbols = set()
    for name in names:
        character = name.removeprefix("num_")
        if len(character) == 1:
            symbols.add(ord(character))
            if character.isdigit():
                symbols.add(getattr(key, f"NUM_{character}"))
    if not sys.platform.startswith("linux"):
        return symbols
    from psychopy.hardware.keyboard import keyNamesLinux
    from pyglet.libs.x11 import xlib

    display = window.winHandle._x_display
    for code, name in keyNamesLinux.items():
        if name in names:
            for level in range(6):  # unshifted, Shift, AltGr levels
                symbol = xlib.XKeycodeToKeysym(display, code - 1, level)
                if symbol:
                    symbols.add(int(symbol))
    return symbols


def key_labels(window, names) -> dict[str, str]:
    """What each key PsychoPy's keyboard calls ``names`` is labelled with in the keyboard
    layout in use: the character it types unshifted, upper case (on a German layout the key
    named ``y``, the US layout's Y, is labelled ``Z``; on a French one ``q`` is ``A``). A key
    that types no character keeps its name, upper case; elsewhere than on X11 every name does.

    Psychtoolbox names keys by their position on a US keyboard on Linux
    (:data:`psychopy.hardware.keyboard.keyNamesLinux`), so a screen that takes the key named
    ``y`` must tell a German participant to press Z.

    Parameters
    ----------
    window
        The open PsychoPy window.
    names
        Key names as PsychoPy's keyboard gives them.

    Returns
    -------
    dict of str to str
        Name → label.
    """
    labels = {name: name.upper() for name in names}
    if not sys.platform.startswith("linux"):
        return labels
    from psychopy.hardware.keyboard import keyNamesLinux
    from pyglet.libs.x11 import xlib

    display = window.winHandle._x_display
    for code, name in keyNamesLinux.items():
        if name in labels:
            symbol = int(xlib.XKeycodeToKeysym(display, code - 1, 0))
            if 0x20 < symbol < 0x100:  # Latin-1 keysyms are their characters
                labels[name] = chr(symbol).upper()
            elif symbol >> 24 == 0x01:  # Unicode keysyms: 0x01000000 + the code point
                labels[name] = chr(symbol & 0xFFFFFF).upper()
    return labels


def dispatch_events(window) -> None:
    """Let the window process its events (keeps it responsive while waiting)."""
    window.winHandle.dispatch_events()


if sys.platform.startswith("linux"):  # pragma: no branch

    def qt_dialog_available() -> bool:
        """Whether Qt can open a dialog on this X display (it aborts the process if not)."""
        import ctypes.util

        return ctypes.util.find_library("xcb-cursor") is not None

    def x_display_answers() -> bool:
        """Whether the X server of ``$DISPLAY`` accepts a connection (Qt aborts the process
        when it does not; pyglet raises). True when libX11 is not there to ask."""
        import ctypes
        import ctypes.util

        name = ctypes.util.find_library("X11")
        if name is None:  # pragma: no cover - PsychoPy's windows need it
            return True
        xlib = ctypes.CDLL(name)
        xlib.XOpenDisplay.restype = ctypes.c_void_p
        xlib.XOpenDisplay.argtypes = [ctypes.c_char_p]
        xlib.XCloseDisplay.argtypes = [ctypes.c_void_p]
        display = xlib.XOpenDisplay(None)
        if not display:
            return False
        xlib.XCloseDisplay(display)
        return True

else:  # pragma: no cover

    def qt_dialog_available() -> bool:
        return True

    def x_display_answers() -> bool:
        return True
