"""What a session's window records beside its trials: the PsychoPy log (every onset, offset and
key press) and the frame intervals of every presentation (``_frames.tsv``).

The trials matter more than these records: a record that can no longer be written (a full disk)
is warned about once and given up, never the session.
"""

from __future__ import annotations

import contextlib
import sys
from pathlib import Path

import numpy as np

__all__ = ["SessionRecords"]


class SessionRecords:
    """The session's PsychoPy log and frame-interval file, each from a line naming its run."""

    def __init__(self):
        self.frames_path: Path | None = None
        self._logfile = None

    def start(
        self,
        marker: str,
        *,
        frames_path: Path | None,
        log_path: Path | None,
        log_lines: list[str],
        window_intervals: list[float],
        live_columns: tuple[str, ...] = (),
    ) -> None:
        """Begin both records with ``marker`` (the run and when it started): the log, with
        ``log_lines`` after it; the frame intervals, with those measured as the window opened.

        Parameters
        ----------
        marker
            The line that starts the run's records (its number and when it started).
        frames_path
            The frame-interval file (``_frames.tsv``), appended to; None: none written.
        log_path
            The PsychoPy log file, appended to; None: none written.
        log_lines
            Lines to log after the marker (what was checked before the window opened).
        window_intervals
            The frame intervals measured as the window opened, s.
        live_columns
            The columns after ``interval_ms`` of a live scene's frames (a new file's header
            names them; :meth:`write_live_row`); default none.
        """
        from psychopy import logging

        self.frames_path = frames_path
        if log_path is not None:
            self._logfile = logging.LogFile(str(log_path), level=logging.EXP, filemode="a")
            logging.exp(marker)
            for line in log_lines:
                logging.exp(line)
        if frames_path is not None:
            try:
                with frames_path.open("a", encoding="utf-8") as handle:
                    if handle.tell() == 0:
                        handle.write("\t".join(("what", "frame", "interval_ms", *live_columns)))
                        handle.write("\n")
                    handle.write(f"{marker}\t\t\n")
                    for index, interval in enumerate(window_intervals, start=1):
                        handle.write(f"window opened\t{index}\t{1000 * interval:.3f}\n")
            except OSError as error:
                self._warn(f"frame intervals not written to {frames_path}", error)
                self.frames_path = None

    def write_intervals(self, what: str, flips: list[float]) -> None:
        """The intervals between ``flips``, each a line ``what``, frame, milliseconds.

        Parameters
        ----------
        what
            What was shown (the line's first field).
        flips
            The flips' times, s, in order.
        """
        if self.frames_path is None:
            return
        try:
            with self.frames_path.open("a", encoding="utf-8") as handle:
                for index, interval in enumerate(np.diff(flips), start=1):
                    handle.write(f"{what}\t{index}\t{1000 * interval:.3f}\n")
        except OSError as error:  # the trials matter more than the frame intervals
            self._warn(f"frame intervals no longer written to {self.frames_path}", error)
            self.frames_path = None

    def open_live(self):
        """The frame file opened for a live scene's rows (:meth:`write_live_row`), or None."""
        if self.frames_path is None:
            return None
        try:
            return self.frames_path.open("a", encoding="utf-8")
        except OSError as error:
            self._warn(f"frame records not written to {self.frames_path}", error)
            self.frames_path = None
            return None

    def write_live_row(self, handle, what: str, values: tuple, interval_s: float | None) -> bool:
        """One frame of a live scene: ``what``, its frame number, flip interval and values,
        flushed at once.

        Parameters
        ----------
        handle
            The file :meth:`open_live` gave.
        what
            What was shown (the line's first field).
        values
            The frame's values, its number first (``glarelab.frontend.live.FRAME_COLUMNS``).
        interval_s
            The flip interval, s; None for the first frame.

        Returns
        -------
        bool
            Whether it was written (False once the file can no longer be written).
        """
        if handle is None or self.frames_path is None:
            return False
        interval = "" if interval_s is None else f"{1000 * interval_s:.3f}"
        try:
            handle.write("\t".join((what, str(values[0]), interval, *map(str, values[1:]))))
            handle.write("\n")
            handle.flush()
        except OSError as error:  # the trials matter more than the frame records
            self._warn(f"frame records no longer written to {self.frames_path}", error)
            self.frames_path = None
            return False
        return True

    def flush(self) -> None:
        """Write the log's lines so far to its file."""
        from psychopy import logging

        try:
            logging.flush()
        except OSError as error:  # the trials matter more than the log
            self._warn("the session log is no longer written", error)
            self.close()

    def close(self) -> None:
        """Stop writing the log (its lines so far are flushed by :meth:`flush`)."""
        from psychopy import logging

        if self._logfile is not None:
            logging.root.removeTarget(self._logfile)
            with contextlib.suppress(OSError):
                self._logfile.stream.close()
            self._logfile = None

    @property
    def logging(self) -> bool:
        """Whether a log file is being written."""
        return self._logfile is not None

    @staticmethod
    def _warn(what: str, error: OSError) -> None:
        print(f"[glarelab] {what} ({error.strerror or error})", file=sys.stderr, flush=True)

    @staticmethod
    def log(message: str) -> None:
        """A line in the session's PsychoPy log (written when the loop waits for keys).

        Parameters
        ----------
        message
            The line.
        """
        from psychopy import logging

        logging.exp(message)
