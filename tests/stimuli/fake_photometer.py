"""Simulated photometers on a pseudo-terminal, for PsychoPy's plugins to talk to: a Konica
Minolta LS-100 / CS-100A, and (at the end of the file) a PR-655 and a ColorCAL.

The device speaks the instrument's serial protocol as ``psychopy-minolta`` uses it: commands
end in CR LF; ``MDS,04`` (absolute mode) answers ``OK00``, ``CLE`` answers ``OK00``, ``MES``
answers ``OK00, <cd/m²>`` (the CS-100A adds ``, <x>, <y>``), anything else ``ER00``; a reading
over the range answers ``ER10`` (measuring range over). The luminance it measures comes from a
``source`` callable (a known display model looking at a drive code, or at the pixel an X
screen shows), with the display's settling after a change (first order, time constant
``settle_tau_s``), the instrument's noise (relative, from a seeded generator), its four
significant digits, its line settings (garbage back when the driver set the line
up otherwise: see :mod:`tests.stimuli.pty_line`), and the faults of a lab: no answer (``mute``), garbage (``garble``), a pulled
cable (``unplug_after`` readings: the pseudo-terminal's master side is closed), drift
(``drift_per_reading``, relative), and any reply in place of the next readings (``faults``).
"""

from __future__ import annotations

import json
import os
import select
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path

import numpy as np

# what comes back at another baud rate or parity than the instrument's: bytes with the high
# bit set, no text (a reply "OK00, 12.34" read at 9600 baud where it was sent at 4800)
WRONG_LINE = "\xf0\x8c\xe6\x9e\xfc\xe0\x80\r\n"

# the line settings each instrument expects
MINOLTA_LINE = {"baud": 4800, "line": "7E2"}  # RS-232C
PR655_LINE = {"baud": 9600, "line": "8N1"}  # USB, a virtual serial port
COLORCAL_LINE = {"baud": 115200, "line": "8N1"}  # USB, a virtual serial port


class FakeSerialPhotometer:
    """A photometer on ``self.port``; a subclass speaks an instrument's protocol."""

    EOL = b"\r\n"  # what ends a command
    LINE = MINOLTA_LINE

    def __init__(
        self,
        source: Callable[[], float],
        *,
        model: str = "LS-100",
        noise_fraction: float = 0.001,
        settle_tau_s: float = 0.0,
        ceiling_cd_m2: float = 299_900.0,
        seed: int = 0,
        line_folder: Path | None = None,
    ):
        self.source = source
        self.model = model
        self.noise_fraction = noise_fraction
        self.settle_tau_s = settle_tau_s
        self.ceiling_cd_m2 = ceiling_cd_m2
        self.rng = np.random.default_rng(seed)
        self.mute = False
        self.garble = False
        self.unplug_after: int | None = None
        self.drift_per_reading = 0.0
        self.faults: list[str] = []  # replies to the next MES commands instead of readings
        self.readings = 0
        self.commands: list[str] = []
        self.replies: list[str] = []
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.port = os.ttyname(self.slave)
        # what the driver set the line to (tests.stimuli.pty_line writes it there)
        self.line_file = (
            None if line_folder is None else Path(line_folder) / (f"{Path(self.port).name}.json")
        )
        self._shown = None  # (luminance now shown, since when, the one before)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()
        self._watch = threading.Thread(target=self._follow, daemon=True)
        self._watch.start()

    # the display in front of the photometer ---------------------------------------------------

    def _follow(self) -> None:
        """Watch the source, to know when the light changed (for the settling)."""
        while not self._stop.is_set():
            self._light()
            time.sleep(0.01)

    def _light(self) -> float:
        value, now = float(self.source()), time.monotonic()
        if self._shown is None:
            self._shown = (value, now, value)
        elif value != self._shown[0]:
            self._shown = (value, now, self._seen(now))
        return self._seen(now)

    def _seen(self, now: float) -> float:
        target, since, before = self._shown
        if self.settle_tau_s <= 0:
            return target
        return target + (before - target) * np.exp(-(now - since) / self.settle_tau_s)

    def measure(self) -> float:
        light = self._light()
        self.readings += 1
        gain = 1.0 + self.drift_per_reading * self.readings
        return light * gain * (1.0 + self.noise_fraction * self.rng.standard_normal())

    # the serial line ----------------------------------------------------------------------------

    def _serve(self) -> None:
        buffer = b""
        while not self._stop.is_set() and self.master >= 0:
            try:
                ready, _, _ = select.select([self.master], [], [], 0.05)
                if not ready:
                    continue
                chunk = os.read(self.master, 1024)
            except (OSError, ValueError):  # no one has the port open (EIO), or unplugged
                if self._stop.is_set():
                    return
                time.sleep(0.01)
                continue
            buffer += chunk
            while self.EOL in buffer:
                line, buffer = buffer.split(self.EOL, 1)
                self._answer(line.decode("ascii", errors="replace").strip())

    def line_ok(self) -> bool:
        """Whether the driver set up the line as the instrument's (when it can be known)."""
        if self.line_file is None:
            return True
        return self.line_file.is_file() and json.loads(self.line_file.read_text()) == self.LINE

    def _send(self, text: str) -> None:
        self.replies.append(text)
        os.write(self.master, text.encode("latin-1"))  # "\xf0" is the byte 0xF0

    def unplug(self) -> None:
        """Pull the cable: the port's other side goes away."""
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass
        self.master = self.slave = -1

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2)
        self._watch.join(timeout=2)
        self.unplug()


class FakeMinolta(FakeSerialPhotometer):
    """An LS-100 (``model='LS-100'``) or CS-100A (``model='CS-100A'``)."""

    def _answer(self, command: str) -> None:
        self.commands.append(command)
        if self.mute:
            return
        if not self.line_ok():
            self._send(WRONG_LINE)
            return
        if self.garble:
            self._send("\x1b7#;~?\r\n")
            return
        if command.startswith("MDS,") or command == "CLE":
            self._send("OK00\r\n")
        elif command == "MES" and self.faults:
            self._send(self.faults.pop(0))
        elif command == "MES":
            value = self.measure()
            if self.unplug_after is not None and self.readings > self.unplug_after:
                self.unplug()
                return
            if value > self.ceiling_cd_m2:
                self._send("ER10\r\n")
            elif self.model == "CS-100A":
                self._send(f"OK00, {value:.4g}, 0.3127, 0.3290\r\n")
            else:
                self._send(f"OK00, {value:.4g}\r\n")
        else:
            self._send("ER00\r\n")


class FakePR655(FakeSerialPhotometer):
    """A Photo Research PR-655 as ``psychopy-photoresearch`` speaks to it: commands end in LF
    (sent a character at a time), replies are comma-separated lines with a status first
    (``0000`` fine); ``D5`` sends the spectrum, a line per wavelength."""

    EOL = b"\n"
    LINE = PR655_LINE

    def __init__(self, source, *, serial_number: str = "65551234", **kwargs):
        kwargs.setdefault("model", "PR-655")
        super().__init__(source, **kwargs)
        self.serial_number = serial_number
        self.last = 0.0

    def _answer(self, command: str) -> None:
        self.commands.append(command)
        if self.mute:
            return
        if self.garble or not self.line_ok():
            self._send("\x1b7#;~?\r\n")
            return
        if command == "PHOTO":
            self._send(" REMOTE MODE\r\n")
        elif command == "D111":
            self._send("0000,PR-655\r\n")
        elif command == "D110":
            self._send(f"0000,{self.serial_number}\r\n")
        elif command == "M0" and self.faults:
            self._send(self.faults.pop(0))
        elif command == "M0":
            self.last = self.measure()
            if self.unplug_after is not None and self.readings > self.unplug_after:
                self.unplug()
                return
            self._send("0000\r\n")
        elif command == "D1":
            self._send(f"0000,0,{self.last:.4e},0.3127,0.3290\r\n")
        elif command == "D2":
            x, z = 0.9505 * self.last, 1.089 * self.last
            self._send(f"0000,0,{x:.4e},{self.last:.4e},{z:.4e}\r\n")
        elif command == "D3":
            self._send(f"0000,0,{self.last:.4e},0.1978,0.4683\r\n")
        elif command == "D4":
            self._send("0000,0,0,6504,0.0003\r\n")
        elif command == "D5":
            lines = ["0000,0\r\n", "380,0\r\n"]
            lines += [f"{nm},{self.last * 1e-3:.4e}\r\n" for nm in range(380, 781, 4)]
            self._send("".join(lines))
        else:
            self._send("-0001\r\n")


class FakeColorCAL(FakeSerialPhotometer):
    """A CRS ColorCAL MKII as ``psychopy-crs`` speaks to it: commands end in LF, replies end in
    LF CR and a ``>`` prompt; ``IDR`` tells the serial number, ``r01``-``r03`` the calibration
    matrix (Minolta's integer code: value × 10000), ``MES`` the raw X, Y, Z."""

    EOL = b"\n"
    LINE = COLORCAL_LINE

    def __init__(self, source, *, serial_number: str = "CC2-00421", **kwargs):
        kwargs.setdefault("model", "ColorCAL")
        super().__init__(source, **kwargs)
        self.serial_number = serial_number

    def _answer(self, command: str) -> None:
        self.commands.append(command)
        if self.mute:
            return
        if self.garble or not self.line_ok():
            self._send("\x1b7#;~?\n\r>")
            return
        if command == "IDR":
            self._send(f"OK00,1,5.02,0,{self.serial_number},0,886\n\r>")
        elif command in ("r01", "r02", "r03"):
            row = [0, 0, 0]
            row[int(command[2]) - 1] = 10000  # an identity matrix
            self._send("OK00," + ",".join(map(str, row)) + "\n\r>")
        elif command == "MES" and self.faults:
            self._send(self.faults.pop(0))
        elif command == "MES":
            value = self.measure()
            if self.unplug_after is not None and self.readings > self.unplug_after:
                self.unplug()
                return
            self._send(f"OK00,{0.9505 * value:.4f},{value:.4f},{1.089 * value:.4f}\n\r>")
        else:
            self._send("ER00\n\r>")
