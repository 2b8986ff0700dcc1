"""What the analysis layer passes around: the validated trials of a study (:class:`Dataset`), a
paradigm's design (:class:`Design`), the error that names every problem of the data
(:class:`DataError`), and the ``flags`` of a paradigm that lists none (:func:`no_flags`).

Reading and checking session files is :mod:`glarelab.analysis.load`'s job; each paradigm's
module (:mod:`glarelab.analysis.paradigms`) analyses a :class:`Dataset` and describes its design
with a :class:`Design`. This module imports nothing of the suite, so that both can use it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import pandas as pd

if TYPE_CHECKING:
    from glarelab.protocols import Protocol

__all__ = ["DataError", "Dataset", "Design", "no_flags", "where"]


class DataError(ValueError):
    """Problems in the input data, each naming file, line and column.

    Parameters
    ----------
    problems
        Every problem found, one line each naming the file, line and column.
    """

    def __init__(self, problems: list[str]):
        self.problems = problems
        shown = "\n".join(f"  - {p}" for p in problems[:50])
        more = f"\n  … and {len(problems) - 50} more" if len(problems) > 50 else ""
        super().__init__(f"{len(problems)} problem(s) in the data:\n{shown}{more}")


@dataclass(frozen=True)
class Design:
    """A paradigm's design as the checks of the data need it.

    Attributes
    ----------
    factors
        The within factors, columns of the trials (e.g. ``("method", "level_index")``).
    cells
        Every combination of the factors' values each participant needs.
    block
        The block whose trials are analysed (``"main"``), or None for every block.
    blocks
        Every block name a session of the protocol writes (a block the experiment never
        writes, such as ``"Training"``, is refused).
    one_trial_per_cell
        Whether each participant has exactly one trial per cell (matching, ratings) or many
        (a staircase's trials at one glare level and context).
    """

    factors: tuple[str, ...]
    cells: tuple[tuple, ...]
    block: str | None
    blocks: tuple[str, ...]
    one_trial_per_cell: bool


@dataclass
class Dataset:
    """Validated trials of one study: ``trials`` (typed DataFrame, in the order of the
    participants, sessions and trial numbers), the sidecars, the participants excluded as
    incomplete (with why), every session file read (``sessions``), the pilot sessions
    left out (``pilots``) or analysed (``pilots_included``), and the trials analysed as
    recorded that the report lists (``flags``: a darker target set above the brighter).

    Attributes
    ----------
    study
        The study's name.
    trials
        The trials analysed, one row per trial, typed by the protocol's columns.
    files
        The session CSVs read.
    sidecars
        CSV → its JSON sidecar.
    excluded
        Participant → why they were excluded as incomplete.
    sessions
        One record per session file read: its participant, session, status and trials.
    pilots
        The pilot sessions left out.
    pilots_included
        Whether pilot sessions were analysed.
    flags
        The trials analysed as recorded that the report lists.
    """

    study: str
    trials: pd.DataFrame
    files: list[str]
    sidecars: dict[str, dict] = field(default_factory=dict)
    excluded: dict[str, str] = field(default_factory=dict)
    sessions: list[dict] = field(default_factory=list)
    pilots: list[dict] = field(default_factory=list)
    pilots_included: bool = False
    flags: list[str] = field(default_factory=list)

    @property
    def incomplete_sessions(self) -> list[dict]:
        """The sessions that did not complete (aborted, interrupted, header only), analysed or
        skipped at the caller's request: the report lists them."""
        return [
            s
            for s in self.sessions
            if s["trials"] == 0 or s["status"] not in ("completed", "no sidecar")
        ]


def where(row) -> str:
    """The file and line of a trial, as problems name them.

    Parameters
    ----------
    row
        A trial (its ``_file`` and ``_line``).

    Returns
    -------
    str
        ``'FILE, line N'``.
    """
    return f"{row['_file']}, line {row['_line']}"


def no_flags(trials: pd.DataFrame, protocol: Protocol) -> list[str]:
    """The ``flags`` of a paradigm whose sessions record no trial that contradicts the task:
    trials to list in the report though analysed as recorded, none.

    Parameters
    ----------
    trials
        The trials read, typed by the protocol's columns (``_file`` and ``_line`` name each).
    protocol : glarelab.protocols.Protocol
        The study's protocol, of this paradigm.

    Returns
    -------
    list of str
        Empty: this paradigm lists none.

    Examples
    --------
    >>> no_flags(pd.DataFrame(), None)
    []
    """
    return []
