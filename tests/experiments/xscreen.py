"""A private X screen for a session under test, driven as a participant would drive it.

Each :class:`XScreen` starts its own Xvfb server, runs ``glarelab run ...`` on it as a separate
process, and sends real key events through the X server with ``xdotool`` (the XTEST extension,
the same path a USB keyboard's events take into the X server). Screenshots are read back from
the X server (the front buffer as shown), not from the program: :meth:`XScreen.codes` reads the
root window with python-xlib, at the screen's own depth (8 or 10 bits per channel), through
neither PsychoPy, OpenGL nor glarelab.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from PIL import ImageGrab

SCREEN = (1920, 1080)


def _need(tool: str) -> str:
    path = shutil.which(tool)
    assert path, f"{tool} is missing: run `make test`, which installs it (scripts/system-deps.sh)"
    return path


class XScreen:
    """An Xvfb display with one ``glarelab`` process on it; ``depth`` bits per pixel (24: 8 bits
    per channel, 30: 10 bits)."""

    def __init__(self, tmp_path: Path, *, depth: int = 24, layout: str | None = None):
        self.tmp_path = Path(tmp_path)
        read, write = os.pipe()
        self.server = subprocess.Popen(
            [
                _need("Xvfb"),
                "-displayfd",
                str(write),
                "-screen",
                "0",
                f"{SCREEN[0]}x{SCREEN[1]}x{depth}",
                "-nolisten",
                "tcp",
                "-noreset",  # Xvfb resets its keyboard layout when its last client leaves
            ],
            pass_fds=(write,),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        os.close(write)
        number = b""
        deadline = time.time() + 30
        while not number.endswith(b"\n") and time.time() < deadline:
            number += os.read(read, 16)
        os.close(read)
        self.display = f":{number.decode().strip()}"
        self.env = {**os.environ, "DISPLAY": self.display}
        if layout is not None:  # e.g. "fr": the keys then make what a French keyboard's make
            subprocess.run([_need("setxkbmap"), layout], env=self.env, check=True)
        self.process: subprocess.Popen | None = None
        self.stderr_path = self.tmp_path / "glarelab.stderr"
        self.stdout_path = self.tmp_path / "glarelab.stdout"

    # --- the program ----------------------------------------------------------------------

    def run(self, *args) -> subprocess.Popen:
        """Start ``glarelab ARGS`` on this screen."""
        self.stderr_file = self.stderr_path.open("w")
        self.stdout_file = self.stdout_path.open("w")
        self.process = subprocess.Popen(
            [sys.executable, "-m", "glarelab", *map(str, args)],
            env=self.env,
            stdout=self.stdout_file,
            stderr=self.stderr_file,
        )
        return self.process

    def glarelab(self, *args, timeout: float = 300) -> subprocess.CompletedProcess:
        """Run ``glarelab ARGS`` on this screen to its end."""
        return subprocess.run(
            [sys.executable, "-m", "glarelab", *map(str, args)],
            env=self.env,
            capture_output=True,
            text=True,
            timeout=timeout,
            check=False,
        )

    def wait(self, timeout: float = 120) -> int:
        """Wait for the program to end; its exit status."""
        code = self.process.wait(timeout=timeout)
        self.stderr_file.close()
        if getattr(self, "stdout_file", None) is not None:  # a process started by run()
            self.stdout_file.close()
        return code

    @property
    def stderr(self) -> str:
        return self.stderr_path.read_text() if self.stderr_path.exists() else ""

    @property
    def stdout(self) -> str:
        return self.stdout_path.read_text() if self.stdout_path.exists() else ""

    def signal(self, number: int) -> None:
        self.process.send_signal(number)

    def wait_for_file(self, pattern: str, folder: Path, timeout: float = 120) -> Path:
        deadline = time.time() + timeout
        while time.time() < deadline:
            found = sorted(Path(folder).glob(pattern))
            if found:
                return found[0]
            self._alive()
            time.sleep(0.05)
        raise AssertionError(f"no {pattern} in {folder} after {timeout} s:\n{self.stderr[-3000:]}")

    def wait_for_log(
        self, folder: Path, pattern: str, timeout: float = 120, *, count: int = 1
    ) -> re.Match:
        """Wait until the session's PsychoPy log has ``count`` lines matching ``pattern``."""
        log = self.wait_for_file("*.log", folder, timeout)
        deadline = time.time() + timeout
        while time.time() < deadline:
            matches = list(re.finditer(pattern, log.read_text(errors="replace")))
            if len(matches) >= count:
                return matches[count - 1]
            self._alive()
            time.sleep(0.02)
        raise AssertionError(f"no {pattern!r} in {log} after {timeout} s:\n{self.stderr[-3000:]}")

    def _alive(self) -> None:
        if self.process is not None and self.process.poll() is not None:
            raise AssertionError(
                f"glarelab ended with {self.process.returncode}:\n{self.stderr[-3000:]}"
            )

    # --- the participant ------------------------------------------------------------------

    def key(self, *names: str, delay_ms: int = 0) -> tuple[float, float]:
        """Press and release each key through the X server; wall-clock times just before the
        first and just after the last press."""
        before = time.time()
        subprocess.run(
            [_need("xdotool"), "key", "--delay", str(delay_ms), *names],
            env=self.env,
            check=True,
        )
        return before, time.time()

    def type(self, text: str) -> None:
        """Type ``text`` through the X server (into the focused window)."""
        subprocess.run([_need("xdotool"), "type", "--delay", "30", text], env=self.env, check=True)

    def wait_for_window(self, name: str, timeout: float = 120) -> str:
        """The id of the first visible window whose title matches ``name``, once it is up."""
        deadline = time.time() + timeout
        while time.time() < deadline:
            found = subprocess.run(
                [_need("xdotool"), "search", "--onlyvisible", "--name", name],
                env=self.env,
                capture_output=True,
                text=True,
                check=False,
            ).stdout.split()
            if found:
                return found[0]
            self._alive()
            time.sleep(0.1)
        raise AssertionError(f"no window {name!r} appeared:\n{self.stderr[-3000:]}")

    def focus_window(self, name: str = "PsychoPy") -> None:
        """Give the program's window the input focus (no window manager does it here)."""
        window = self.wait_for_window(name)
        subprocess.run(
            [_need("xdotool"), "windowfocus", "--sync", window], env=self.env, check=False
        )

    def screenshot(self, bbox=None) -> np.ndarray:
        """What the X server shows now (RGB), optionally a (left, top, right, bottom) box."""
        return np.asarray(ImageGrab.grab(bbox=bbox, xdisplay=self.display).convert("RGB"))

    def codes(self, box: tuple[int, int, int, int]) -> np.ndarray:
        """The codes the X server shows in ``box`` (left, top, width, height; root-window
        pixels from the top-left corner): (height, width, 3) integers at the screen's bits per
        channel (8 at depth 24, 10 at depth 30), each channel cut out of the pixel by the root
        visual's own masks."""
        from Xlib import X
        from Xlib import display as xdisplay

        if getattr(self, "_x", None) is None:
            self._x = xdisplay.Display(self.display)
        screen = self._x.screen()
        visual = next(
            v
            for depth in screen.allowed_depths
            for v in depth.visuals
            if v.visual_id == screen.root_visual
        )
        left, top, width, height = (int(v) for v in box)
        image = screen.root.get_image(left, top, width, height, X.ZPixmap, 0xFFFFFFFF)
        assert image.depth == screen.root_depth in (24, 30), image.depth
        pixels = np.frombuffer(image.data, dtype="<u4").reshape(height, width)
        channels = []
        for mask in (visual.red_mask, visual.green_mask, visual.blue_mask):
            shift = (mask & -mask).bit_length() - 1
            channels.append((pixels & mask) >> shift)
        return np.stack(channels, axis=-1).astype(np.int64)

    def close(self) -> None:
        if getattr(self, "_x", None) is not None:
            self._x.close()
            self._x = None
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGKILL)
            self.process.wait()
        self.server.terminate()
        self.server.wait(timeout=30)


def sidecar_of(csv: Path) -> dict:
    return json.loads(csv.with_suffix(".json").read_text())
