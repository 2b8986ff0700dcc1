"""Default answers of simulated participants in Luidolt's (2020, §7.2.1) questionnaire.

Five participants rated six categories from 1 ("completely different") to 7 ("exactly the
same"), comparing the VR simulation with what they had seen in a real room. §7.2.1 prints the
constraints these defaults follow (the per-rating bar charts, Figures 7.1-7.7, are not in the
text):

- **Glare Appearance**: "only the glare appearance voted 3.9 on average"; everyone found the
  simulated glare coarser and too intense, some found the rainbow rings realistic.
- **Glare Movement**: one participant "rated the effect ... to be just perfect" (a 7), others
  criticised how the glare faded, stayed too intense or did not tilt.
- **Eye Adaptation**: "commented on very positively, most participants said it resembled
  their perception a lot"; the adaptation to the dark was too slow.
- **Visual Acuity**: "voted as entirely equal to their perception by four out of five"; the
  fifth found it "way too intense": a low rating. Four 7s make the mean at least 5.8.
- **Scotopic Vision**: "two participants noted that the colors completely matched" (two 7s);
  one found the shift too intense, one not intense enough, one saw some areas too bright.
- **Overall**: "one participant rated it to be neither good nor bad" (a 4), "all the others
  found it good or very good" (5 or 6), "no one rated it as perfect" (no 7); with the mean of at
  least 5, at least one 6, so the mean lies in 5.0-5.6.
- Five of the six categories average 5 or above.

Each category's ratings are drawn from a probability per rating (1 … 7) whose expected counts
out of five participants follow those statements; ``docs/observers.md`` shows the expected means
and how often a simulated group of five reproduces each statement.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

__all__ = [
    "LUIDOLT_CATEGORIES",
    "LUIDOLT_RATING_PROBABILITIES",
    "draw_rating",
    "expected_rating",
]

LUIDOLT_CATEGORIES = (
    "Glare Appearance",
    "Glare Movement",
    "Eye Adaptation",
    "Visual Acuity",
    "Scotopic Vision",
    "Overall",
)
"""The six categories of Luidolt 2020 §7.2.1, in the order they were asked."""

LUIDOLT_RATING_PROBABILITIES = MappingProxyType(
    {
        # P(rating = 1, 2, ..., 7)
        # mean 3.9 (§7.2.1); coarse, too intense, yet some rings realistic: mostly 3-5
        "Glare Appearance": (0.05, 0.10, 0.20, 0.30, 0.25, 0.10, 0.00),
        # one "just perfect" out of five; the others with reservations: mean 5.3
        "Glare Movement": (0.00, 0.00, 0.10, 0.15, 0.30, 0.25, 0.20),
        # "very positively", "resembled their perception a lot", adaptation too slow: mean 5.7
        "Eye Adaptation": (0.00, 0.00, 0.00, 0.10, 0.30, 0.40, 0.20),
        # four of five "entirely equal" (7), one "way too intense" (2 or 3): mean 6.1
        "Visual Acuity": (0.00, 0.10, 0.10, 0.00, 0.00, 0.00, 0.80),
        # two of five "completely matched" (7); three with a shift too strong, too weak or
        # uneven: mean 5.5
        "Scotopic Vision": (0.00, 0.00, 0.10, 0.20, 0.20, 0.10, 0.40),
        # one 4 ("neither good nor bad"), the others 5 or 6 ("good or very good"), no 7: 5.2
        "Overall": (0.00, 0.00, 0.00, 0.20, 0.40, 0.40, 0.00),
    }
)
"""Probability of each rating 1-7 per category (each row sums to 1)."""


def _probabilities(category: str) -> np.ndarray:
    if category not in LUIDOLT_RATING_PROBABILITIES:
        raise ValueError(
            f"category must be one of {', '.join(repr(c) for c in LUIDOLT_CATEGORIES)}; "
            f"got {category!r}"
        )
    return np.asarray(LUIDOLT_RATING_PROBABILITIES[category], dtype=float)


def expected_rating(category: str) -> float:
    """The expected rating of ``category`` (1-7).

    Raises
    ------
    ValueError
        For a category not in :data:`LUIDOLT_CATEGORIES`.

    Examples
    --------
    >>> round(expected_rating("Glare Appearance"), 2)
    3.9
    """
    return float(np.dot(np.arange(1, 8), _probabilities(category)))


def draw_rating(category: str, rng: np.random.Generator) -> int:
    """One participant's rating of ``category``, drawn from ``rng``.

    Raises
    ------
    ValueError
        For a category not in :data:`LUIDOLT_CATEGORIES`, or ``rng`` not a numpy Generator.

    Examples
    --------
    >>> draw_rating("Overall", np.random.default_rng(0)) in (4, 5, 6)
    True
    """
    p = _probabilities(category)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator; got {type(rng).__name__}")
    return int(rng.choice(7, p=p)) + 1
