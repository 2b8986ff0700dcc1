"""What every protocol engine shares: seeded randomness per participant, and the interface.

An engine is a plain state machine. ``screen()`` says what to show now (a dict: ``kind`` and
what the front-end needs to draw it); ``press(key, t)`` takes a key press at ``t`` seconds
after the current screen appeared and returns the finished trial's row (a dict of
:mod:`experiments.schema` columns) when that key ended a trial, else None. ``done`` says the
session is over. ``replay(rows)`` rebuilds the state after the rows already on disk, to resume.
"""

from __future__ import annotations

import hashlib

import numpy as np

__all__ = ["participant_rng"]


def participant_rng(seed: int, participant: str, purpose: str) -> np.random.Generator:
    """A generator fixed by the protocol seed, the participant and what it is for, so that a
    participant's trial order is the same in every run and resumed session."""
    digest = hashlib.sha256(f"{participant}/{purpose}".encode()).digest()
    return np.random.default_rng([seed, int.from_bytes(digest[:8], "little")])
