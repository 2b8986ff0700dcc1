"""A rating questionnaire (Luidolt 2020, §7.2.1): keys, rules and CSV columns.

Each category is rated on a scale of number keys (Luidolt: 1 = completely different, 7 =
exactly the same), optionally with a typed comment.
"""

from __future__ import annotations

from pathlib import Path

from .columns import Column
from .common import INSTRUCTIONS
from .keys import Key, Schema

__all__ = ["SCHEMA", "check", "columns"]

SCHEMA: Schema = {
    "instructions": INSTRUCTIONS,
    "questionnaire": {
        "scale_min": Key(int, "lowest rating (a number key)", low=0, high=8),
        "scale_max": Key(int, "highest rating (a number key)", low=1, high=9),
        "anchors": Key(list, "labels of the lowest and highest rating", item=str, length=2),
        "categories": Key(list, "category names", item=str, length=(1, 30), unique=True),
        "prompts": Key(list, "one question per category", item=str, length=(1, 30)),
        "comments": Key(bool, "ask for an optional comment per category"),
    },
    "observer": {
        "ratings": Key(
            dict,
            "simulated observers: the probability of each rating, scale_min to scale_max, per "
            "category (category = [p, …]); a category not given: every rating alike",
            default={},
        ),
    },
}


def check(p: dict, problems: list[str], folder: Path | None) -> None:
    q = p["questionnaire"]
    if q["scale_min"] >= q["scale_max"]:
        problems.append("questionnaire.scale_min: must be below questionnaire.scale_max")
    if len(q["categories"]) != len(q["prompts"]):
        problems.append("questionnaire.prompts: one prompt per category is needed")
    size = q["scale_max"] - q["scale_min"] + 1
    for category, probabilities in p["observer"]["ratings"].items():
        where = f"observer.ratings.{category!r}"
        if category not in q["categories"]:
            problems.append(f"{where}: not a category of questionnaire.categories")
        elif (
            not isinstance(probabilities, list)
            or len(probabilities) != size
            or not all(isinstance(x, int | float) and 0 <= x <= 1 for x in probabilities)
            or abs(sum(probabilities) - 1.0) > 1e-6
        ):
            problems.append(
                f"{where} = {probabilities!r}: must be {size} probabilities (ratings "
                f"{q['scale_min']}-{q['scale_max']}), each in [0, 1], summing to 1"
            )


def columns(protocol) -> tuple[Column, ...]:
    """The paradigm's CSV columns for this protocol (after the common ones)."""
    q = (protocol.data if hasattr(protocol, "data") else protocol)["questionnaire"]
    low, high = q["anchors"]
    return (
        Column("category", str, "questionnaire category", choices=tuple(q["categories"])),
        Column(
            "rating",
            int,
            f"rating ({q['scale_min']} = {low}, {q['scale_max']} = {high})",
            low=q["scale_min"],
            high=q["scale_max"],
        ),
        Column("comment", str, "optional comment", optional=True),
    )
