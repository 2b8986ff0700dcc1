"""A rating questionnaire (Luidolt 2020, §7.2.1): keys, rules and CSV columns.

Each category is rated on a scale of number keys (Luidolt: 1 = completely different, 7 =
exactly the same), optionally with a typed comment.

A study that shows what it asks about adds a ``[scene]`` (a rendered night scene, still or a
sequence, see :mod:`glarelab.stimuli.night`) and ``[[conditions]]``: the pipeline of
:func:`glarelab.glare.render_night` with a set of its effects each. Every condition's scene is
shown, frame-exact, before its questions; the rows name the condition.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from glarelab.protocols.columns import Column
from glarelab.protocols.common import (
    DISPLAY,
    INSTRUCTIONS,
    VIEWING,
    check_display,
    repeated_names,
)
from glarelab.protocols.keys import Key, Schema, Tables, validate

if TYPE_CHECKING:
    from glarelab.protocols.core import Protocol

__all__ = [
    "CONDITION",
    "EFFECTS",
    "LIVE_EFFECTS",
    "SCENE",
    "SCHEMA",
    "SESSION_ORDER",
    "check",
    "columns",
    "scene_glare_model",
]

EFFECTS = (
    "adaptation",
    "glare",
    "acuity",
    "scotopic",
)  # glarelab.glare.night.EFFECTS, Luidolt's order
# what a live scene renders per frame (glarelab.glare.night.live.LiveNight): adaptation and
# glare always, the acuity loss and scotopic colour as options
LIVE_EFFECTS = ("adaptation", "glare", "acuity", "scotopic")
LIVE_REQUIRED = ("adaptation", "glare")
SCENE: Schema = {
    "kind": Key(str, "the procedural scene (glarelab.stimuli.night)", choices=("street",)),
    "size_px": Key(list, "scene size (width, height)", item=int, length=2, low=16, high=4096),
    "pixel_deg": Key(
        float,
        "visual angle of a pixel (0: from the display geometry)",
        unit="deg",
        low=0.0,
        high=1.0,
        default=0.0,
    ),
    "lamps": Key(int, "street lamps along the street", low=1, high=12),
    "lamp_cd_m2": Key(float, "luminance of a lamp's bulb", unit="cd/m²", low=1.0, high=1e9),
    "ambient_cd_m2": Key(
        float, "the night's ambient luminance (sky, far walls)", unit="cd/m²", low=0.0, high=1e3
    ),
    "sequence": Key(
        str,
        "what is shown: one still frame, the eye adapting after entering the dark, or a "
        "gaze that moves from the dark to a lamp and back",
        choices=("still", "enter_dark", "gaze"),
    ),
    "seconds": Key(float, "how long the scene is shown", unit="s", low=0.05, high=60.0),
    "frame_rate_hz": Key(
        float,
        "rendered frames per second of a sequence (each shown for a whole number of refreshes)",
        unit="Hz",
        low=1.0,
        high=240.0,
        default=10.0,
    ),
    "start_cd_m2": Key(
        float,
        "enter_dark: the luminance the eye was adapted to before",
        unit="cd/m²",
        low=0.0,
        high=1e6,
        default=100.0,
    ),
    "adapted_display_cd_m2": Key(
        float,
        "display luminance of the adapting luminance (the exposure's key)",
        unit="cd/m²",
        low=0.001,
        high=1e5,
        default=10.0,
    ),
    "glare_model": Key(str, "a glare model of glare.GLARE_MODELS", default="vos"),
    "glare_parameters": Key(dict, "the glare model's parameters", default={}),
    "seed": Key(int, "seed of the scene's random details", low=0, default=0),
    "live": Key(
        bool,
        "shown live for an eye tracker's gaze and pupil (glarelab run --eyetracker): each "
        "refresh rendered for the current gaze for `seconds` of free viewing, no stimulus set",
        default=False,
    ),
    "blank_before_ms": Key(
        float,
        "blank screen before each showing",
        unit="ms",
        low=0.0,
        high=10_000.0,
        default=500.0,
    ),
}
CONDITION: Schema = {
    "name": Key(str, "the condition's name in the data", token=True),
    "title": Key(str, "the condition's name in figures", default=""),
    "effects": Key(
        list,
        "the effects of the pipeline applied",
        item=str,
        length=(0, 4),
        unique=True,
        choices=EFFECTS,
    ),
}

SESSION_ORDER: tuple[str, ...] = ()
"""The sidecar fields in which a session records its participant's order: none (the
conditions' order is seeded per participant and checked row by row); its ``counterbalance`` and
``trial_order`` are null."""

SCHEMA: Schema = {
    "instructions": INSTRUCTIONS,
    "display": Key(dict, "the display (needed with a scene): as in every protocol", default=None),
    "viewing": Key(dict, "the viewing geometry (needed with a scene)", default=None),
    "scene": Key(dict, "a night scene shown before each condition's questions", default=None),
    "conditions": Tables(
        CONDITION, "the pipeline's effects per condition (needs a scene)", (1, 20), default=[]
    ),
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
        "category_effects": Key(
            dict,
            "simulated observers: the effect each category is about (category = effect)",
            default={},
        ),
        "missing_effect_shift": Key(
            float,
            "simulated observers: how much lower a category is rated when its effect is off",
            low=0.0,
            high=8.0,
            default=0.0,
        ),
    },
}


# a sequence's frames are float32 RGB in memory (12 bytes a pixel) while its set is built:
# 1e8 pixel-frames is 1.1 GiB, thirteen times the night2026 scene (640 × 400 px × 30 frames)
MAX_PIXEL_FRAMES = 1e8


def check(p: dict, problems: list[str], folder: Path | None) -> None:
    """Rules between keys: the scene and its conditions, the scale, one prompt per category,
    and the simulated observer's categories, effects and rating probabilities.

    Parameters
    ----------
    p
        The protocol's tables, each validated against the paradigm's :data:`SCHEMA` (defaults
        filled in); called only when that found no problem.
    problems
        The list each problem is appended to, one line naming the keys and their values.
    folder
        The protocol file's folder, which relative paths in it are read from; ``None``: the
        working folder.
    """
    q = p["questionnaire"]
    _check_scene(p, problems)
    scale_ok = q["scale_min"] < q["scale_max"]
    if not scale_ok:
        problems.append(
            f"questionnaire.scale_min = {q['scale_min']!r}: must be below "
            f"questionnaire.scale_max = {q['scale_max']!r} (a scale of at least two ratings)"
        )
    if len(q["categories"]) != len(q["prompts"]):
        problems.append("questionnaire.prompts: one prompt per category is needed")
    for key in ("categories", "prompts", "anchors"):
        for index, text in enumerate(q.get(key) or []):
            if isinstance(text, str) and not text.strip():
                problems.append(
                    f"questionnaire.{key}[{index}] is empty: a participant would see nothing "
                    "there (give its words)"
                )
    anchors = q.get("anchors") or []
    if len(anchors) == 2 and isinstance(anchors[0], str) and anchors[0] == anchors[1]:
        problems.append(
            f"questionnaire.anchors = {anchors!r}: the scale's two ends say the same; give "
            "each end its own words"
        )
    size = q["scale_max"] - q["scale_min"] + 1
    _check_effect_shift(p, problems)
    for category, effect in p["observer"]["category_effects"].items():
        where = f"observer.category_effects.{category!r}"
        if category not in q["categories"]:
            problems.append(f"{where}: not a category of questionnaire.categories")
        elif effect not in EFFECTS:
            problems.append(f"{where} = {effect!r}: must be one of {', '.join(EFFECTS)}")
    for category, probabilities in p["observer"]["ratings"].items():
        where = f"observer.ratings.{category!r}"
        if category not in q["categories"]:
            problems.append(f"{where}: not a category of questionnaire.categories")
        elif scale_ok and (
            not isinstance(probabilities, list)
            or len(probabilities) != size
            or not all(isinstance(x, int | float) and 0 <= x <= 1 for x in probabilities)
            or abs(sum(probabilities) - 1.0) > 1e-6
        ):
            problems.append(
                f"{where} = {probabilities!r}: must be {size} probabilities (ratings "
                f"{q['scale_min']}-{q['scale_max']}), each in [0, 1], summing to 1"
            )


def _check_effect_shift(p: dict, problems: list[str]) -> None:
    """The simulated observers' shift for a missing effect acts only together: a category's
    effect, a shift above 0, and conditions that leave effects out."""
    observer = p["observer"]
    effects, shift = observer["category_effects"], observer["missing_effect_shift"]
    if not (effects or shift):
        return
    conditions = p["conditions"] or []
    if not conditions:
        problems.append(
            f"observer.{'category_effects' if effects else 'missing_effect_shift'}: only a "
            "study with [[conditions]] uses it (a category is rated lower when the condition "
            "shown lacks its effect); remove it"
        )
    elif not effects:
        problems.append(
            f"observer.missing_effect_shift = {shift!r}: no observer.category_effects names "
            "the effect a category is about, so nothing is shifted; give them, or remove it"
        )
    elif not shift:
        problems.append(
            "observer.category_effects: without observer.missing_effect_shift (default 0) a "
            "missing effect lowers no rating; give the shift, or remove them"
        )


def _check_scene(p: dict, problems: list[str]) -> None:
    """A scene needs the display, the viewing geometry and conditions; conditions need a
    scene; the tables are validated in place (defaults filled in)."""
    scene, conditions = p["scene"], p["conditions"]
    if scene is None:
        if conditions:
            problems.append("[[conditions]]: need a [scene] to show")
        for name in ("display", "viewing"):
            if p[name] is not None:
                problems.append(f"[{name}]: only a study with a [scene] uses it")
        return
    given = set(scene) if isinstance(scene, dict) else set()
    p["scene"] = validate(scene, SCENE, "scene", problems)
    for name, schema in (("display", DISPLAY), ("viewing", VIEWING)):
        if p[name] is None:
            problems.append(f"[{name}]: missing (a study with a [scene] shows it on a display)")
        else:
            p[name] = validate(p[name], schema, name, problems)
    if problems:
        return
    check_display(p["display"], problems)
    adapted, white = p["scene"]["adapted_display_cd_m2"], p["display"]["max_cd_m2"]
    if isinstance(white, (int, float)) and adapted > white:
        problems.append(
            f"scene.adapted_display_cd_m2 = {adapted:g}: above the display's white "
            f"(display.max_cd_m2 = {white:g}); the adapting luminance is shown at most at white"
        )
    if not conditions:
        problems.append("[[conditions]]: missing (a [scene] is shown once per condition)")
        return
    names = [c["name"] for c in conditions]
    repeated = repeated_names(names)
    if repeated:
        problems.append(
            f"conditions: names repeat {repeated}: each must be different (ignoring case)"
        )
    seen: dict[frozenset, str] = {}
    for condition in conditions:  # the same effects render the same frames
        effects = frozenset(condition["effects"])
        if effects in seen:
            problems.append(
                f"conditions {seen[effects]!r} and {condition['name']!r}: the same effects "
                f"{sorted(effects)}, so the same frames under two names (their ratings "
                "could differ only by chance); give each condition its own effects"
            )
        else:
            seen[effects] = condition["name"]
    model = p["scene"]["glare_model"]
    if not any("glare" in c["effects"] for c in conditions):  # the keys would shape nothing
        for key in ("glare_model", "glare_parameters"):
            if key in given:
                problems.append(
                    f"scene.{key} = {p['scene'][key]!r}: no condition's effects include "
                    "'glare', so no frame is rendered with it; remove it, or add 'glare' to a "
                    "condition"
                )
    else:
        from glarelab.protocols.common import check_glare_model

        check_glare_model(  # as the frames start from it (a halo's options taken)
            model,
            _start_parameters(p["scene"]),
            "scene",
            problems,
            keys=("glare_model", "glare_parameters"),
        )
        parameters = p["scene"]["glare_parameters"] or {}
        # a nested model's too (hybrid's wave = {pupil_mm = 4})
        fixed = [k for k in (*SCENE_EYE_STATE, *SCENE_UNUSED) if k in parameters] + [
            f"{k}.{inner}"
            for k, v in parameters.items()
            if isinstance(v, dict)
            for inner in (*SCENE_EYE_STATE, *SCENE_UNUSED)
            if inner in v
        ]
        if fixed:
            shown = {
                k: parameters[k] if "." not in k else parameters[k.split(".")[0]][k.split(".")[1]]
                for k in fixed
            }
            problems.append(
                f"scene.glare_parameters: {', '.join(f'{k} = {v!r}' for k, v in shown.items())}"
                ": a scene's eye state is each frame's (the pupil and regime of its adapted "
                "luminance, or a live scene's tracked pupil), so the value would be ignored; "
                "remove it"
            )
    if "start_cd_m2" in given and p["scene"]["sequence"] != "enter_dark":  # would do nothing
        problems.append(
            f"scene.start_cd_m2 = {p['scene']['start_cd_m2']!r}: only an 'enter_dark' sequence "
            f"uses it (the eye's luminance before), not scene.sequence = "
            f"{p['scene']['sequence']!r}; remove it"
        )
    if p["scene"]["live"] and "frame_rate_hz" in given:  # a value there would do nothing
        problems.append(
            f"scene.frame_rate_hz = {p['scene']['frame_rate_hz']!r}: not used by a live scene "
            "(it renders at every refresh); remove it"
        )
    if p["scene"]["live"]:
        _check_live(p, problems)
        return
    rate_hz, refresh_hz = p["scene"]["frame_rate_hz"], p["display"]["refresh_hz"]
    if rate_hz > refresh_hz:
        problems.append(
            f"scene.frame_rate_hz = {rate_hz:g}: above the display's refresh "
            f"(display.refresh_hz = {refresh_hz:g}); each frame is shown for whole refreshes"
        )
    elif abs(refresh_hz / rate_hz - round(refresh_hz / rate_hz)) > 1e-6:
        problems.append(
            f"scene.frame_rate_hz = {rate_hz:g}: each frame must last a whole number of "
            f"refreshes of the {refresh_hz:g} Hz display (e.g. {refresh_hz / 2:g} or "
            f"{refresh_hz / 6:g} Hz)"
        )
    seconds = p["scene"]["seconds"]
    if p["scene"]["sequence"] == "still" and "frame_rate_hz" in given:
        problems.append(
            f"scene.frame_rate_hz = {rate_hz:g}: a still scene is one frame, shown for "
            "scene.seconds; remove it"
        )
    elif p["scene"]["sequence"] != "still" and (
        seconds * rate_hz < 1 - 1e-9 or abs(seconds * rate_hz - round(seconds * rate_hz)) > 1e-6
    ):
        problems.append(
            f"scene.seconds = {seconds:g}: must be a whole number of frames, at least one, at "
            f"scene.frame_rate_hz = {rate_hz:g} ({1 / rate_hz:g} s each); it would be shown "
            f"for {max(1, round(seconds * rate_hz)) / rate_hz:g} s"
        )
    width, height = p["scene"]["size_px"]
    frames = max(1, round(seconds * rate_hz))
    if width * height * frames > MAX_PIXEL_FRAMES:
        problems.append(
            f"scene: {width} × {height} px × {frames} frames ({p['scene']['seconds']:g} s at "
            f"{rate_hz:g} Hz) is {width * height * frames:.3g} pixel-frames, about "
            f"{width * height * frames * 12 / 2**30:.0f} GiB per condition; at most "
            f"{MAX_PIXEL_FRAMES:.0e} (a smaller scene, a shorter or slower sequence)"
        )
    screen_w, screen_h = p["display"]["resolution_px"]
    if width > screen_w or height > screen_h:
        problems.append(
            f"scene.size_px = {[width, height]}: must fit the display's "
            f"{[screen_w, screen_h]} pixels"
        )


# the glare model's fields a scene sets per frame (glare.night.pipeline.adapted_model, LiveNight)
SCENE_EYE_STATE = ("pupil_mm", "regime")
# and the one a given pupil makes unused (a wave model's field luminance sets its pupil)
SCENE_UNUSED = ("field_luminance_cd_m2",)
# a recorded scene's model starts in the mesopic regime: each frame replaces it with its own,
# and a frame without a halo (photopic, a pupil under 3 mm) unsets what shapes the halo
SCENE_START_REGIME = "mesopic"


def scene_glare_model(scene: dict):
    """The glare model a scene's frames start from (:func:`glarelab.protocols.common.glare_model`
    of ``glare_model`` and ``glare_parameters``): a recorded scene's Vos PSF in the mesopic
    regime (:data:`SCENE_START_REGIME`, which every frame replaces), so that the options of
    its halo are taken; a live scene's as given (its frames set only the pupil).

    Parameters
    ----------
    scene
        A validated protocol's ``[scene]`` table.

    Returns
    -------
    glarelab.glare.GlareModel
        The model.

    Raises
    ------
    ValueError, TypeError
        As :func:`glarelab.protocols.common.glare_model` raises them.
    """
    from glarelab.protocols.common import glare_model

    return glare_model(scene["glare_model"], _start_parameters(scene))


def _start_parameters(scene: dict) -> dict:
    """The scene's glare parameters with the regime its frames start from (see above)."""
    import dataclasses

    from glarelab.glare import GLARE_MODELS

    parameters = dict(scene.get("glare_parameters") or {})
    cls = GLARE_MODELS.get(scene.get("glare_model"))
    takes_regime = (
        cls is not None
        and dataclasses.is_dataclass(cls)
        and "regime" in {f.name for f in dataclasses.fields(cls)}
    )
    if takes_regime and not scene.get("live") and "regime" not in parameters:
        parameters["regime"] = SCENE_START_REGIME
    return parameters


def _check_live(p: dict, problems: list[str]) -> None:
    """A live scene: a still street rendered per refresh, with the effects a frame renders."""
    scene = p["scene"]
    if scene["sequence"] != "still":
        problems.append(
            f"scene.sequence = {scene['sequence']!r}: a live scene (scene.live = true) follows "
            "the eye, so its sequence must be 'still'"
        )
    for condition in p["conditions"]:
        effects = condition["effects"]
        missing = [e for e in LIVE_REQUIRED if e not in effects]
        extra = [e for e in effects if e not in LIVE_EFFECTS]
        if missing or extra:
            problems.append(
                f"conditions {condition['name']!r}: effects = {effects!r}: a live scene renders "
                f"{', '.join(LIVE_REQUIRED)} always, acuity and scotopic as options "
                f"({'missing ' + ', '.join(missing) if missing else 'not ' + ', '.join(extra)})"
            )
    width, height = scene["size_px"]
    screen_w, screen_h = p["display"]["resolution_px"]
    if width > screen_w or height > screen_h:
        problems.append(
            f"scene.size_px = {[width, height]}: must fit the display's "
            f"{[screen_w, screen_h]} pixels"
        )


def columns(protocol: Protocol) -> tuple[Column, ...]:
    """The paradigm's CSV columns for this protocol (after the common ones).

    Parameters
    ----------
    protocol : glarelab.protocols.Protocol
        A loaded protocol of this paradigm.

    Returns
    -------
    tuple of glarelab.protocols.columns.Column
        The columns, in file order.
    """
    data = protocol.data if hasattr(protocol, "data") else protocol
    q = data["questionnaire"]
    low, high = q["anchors"]
    condition = ()
    if data.get("conditions"):
        names = tuple(c["name"] for c in data["conditions"])
        condition = (
            Column("condition", str, "the pipeline whose scene was rated", choices=names),
            Column(
                "offset_s",
                float,
                "the flip that ended the scene's presentation (the condition's first category)",
                unit="s",
                low=0.0,
                optional=True,
            ),
            Column(
                "shown_ms",
                float,
                "measured presentation of the scene: offset flip minus onset flip",
                unit="ms",
                low=0.0,
                optional=True,
            ),
        )
    return (
        *condition,
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
