"""Tables every paradigm's protocol shares: the study, the display, the viewing geometry, the
instructions, backgrounds and glare methods (any registered glare model with its parameters).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from glarelab.protocols.keys import Key, Schema, validate

__all__ = [
    "BACKGROUNDS",
    "BREAK_EVERY",
    "DISPLAY",
    "INSTRUCTIONS",
    "LEVELS_CD_M2",
    "LEVEL_LABELS",
    "METHOD",
    "VIEWING",
    "check_background",
    "check_display",
    "check_glare_model",
    "check_methods",
    "display_pixel_deg",
    "glare_model",
    "repeated_names",
]

DISPLAY: Schema = {
    "name": Key(str, "display model, for the record"),
    "resolution_px": Key(list, "pixels (width, height)", item=int, length=2, low=1, high=16384),
    "diagonal_in": Key(float, "visible diagonal", unit="in", low=1.0, high=400.0, default=None),
    "pixel_pitch_mm": Key(float, "pixel pitch", unit="mm", low=0.01, high=10.0, default=None),
    "max_cd_m2": Key(float, "maximum luminance", unit="cd/m²", low=1.0, high=1e5),
    "black_cd_m2": Key(float, "black level", unit="cd/m²", low=0.0, high=100.0, default=0.0),
    "bit_depth": Key(int, "bits per channel of the display", choices=(8, 10, 12, 16)),
    "refresh_hz": Key(
        float, "nominal refresh rate", unit="Hz", low=20.0, high=1000.0, default=60.0
    ),
    "white_tolerance": Key(
        float,
        "largest relative difference between a session's calibration white and max_cd_m2",
        low=0.0,
        high=1.0,
        default=0.1,
    ),
}
VIEWING: Schema = {
    "distance_m": Key(float, "eye-screen distance", unit="m", low=0.1, high=20.0),
    "room_lux": Key(float, "room illumination at the eye", unit="lx", low=0.0, high=1e5),
}
INSTRUCTIONS: Schema = {"text": Key(str, "written instruction shown before the first trial")}
BREAK_EVERY = Key(
    int,
    "a break screen after every this many trials (0: no breaks)",
    low=0,
    high=100_000,
    default=0,
)
LEVEL_LABELS = Key(
    list, "level labels (in the data and the report)", item=str, length=(1, 26), token=True,
    unique=True,
)  # fmt: skip
LEVELS_CD_M2 = Key(
    list,
    "input disk luminances L_disk, one per label (the first label the dimmest)",
    unit="cd/m²",
    item=float,
    length=(1, 26),
    low=0.0,
    high=1e9,
    ascending=True,
)


def check_display(display: dict | None, problems: list[str]) -> None:
    """Rules between the display's keys: one of ``diagonal_in`` and ``pixel_pitch_mm``, and
    the black level below the white.

    Parameters
    ----------
    display
        The ``[display]`` table as :func:`~glarelab.protocols.keys.validate` returned it;
        ``None`` or empty (a table with problems of its own) is not checked.
    problems
        The list each problem found is appended to, one line naming the key and its value.
    """
    if not display:
        return
    if (display["diagonal_in"] is None) == (display["pixel_pitch_mm"] is None):
        problems.append("display: give exactly one of diagonal_in and pixel_pitch_mm")
    if display["black_cd_m2"] >= display["max_cd_m2"]:
        problems.append(
            f"display.black_cd_m2 = {display['black_cd_m2']!r}: must be below "
            f"display.max_cd_m2 = {display['max_cd_m2']!r}"
        )


# --- backgrounds -----------------------------------------------------------------------------

_KIND = Key(str, "what the background is", choices=("sky", "uniform", "lamp", "exr"))
BACKGROUNDS: dict[str, Schema] = {
    "sky": {
        "kind": _KIND,
        "mean_cd_m2": Key(float, "mean luminance of the sky", unit="cd/m²", low=0.0, high=1e4),
        "contrast": Key(float, "RMS contrast of the sky (SD / mean)", low=0.0, high=1.0),
        "cloud_min_deg": Key(float, "smallest cloud structure", unit="deg", low=0.001, high=60.0),
        "cloud_max_deg": Key(float, "largest cloud structure", unit="deg", low=0.001, high=600.0),
        "spectrum_slope": Key(
            float, "amplitude spectrum ∝ f^-slope between the cloud sizes", low=0.0, high=4.0
        ),
    },
    "uniform": {
        "kind": _KIND,
        "cd_m2": Key(float, "luminance of the field", unit="cd/m²", low=0.0, high=1e5),
    },
    "lamp": {
        "kind": _KIND,
        "peak_cd_m2": Key(
            float,
            "the lamp scene's scale: its surfaces stay below 15 % of this",
            unit="cd/m²",
            low=0.0,
            high=1e5,
        ),
    },
    "exr": {
        "kind": _KIND,
        "path": Key(
            str,
            "a linear luminance EXR (cd/m²), relative to the protocol file; a stimulus set "
            "keeps a copy under this path in its backgrounds folder and is proven from it, so "
            "a relative path must not leave the protocol's folder ('..')",
        ),
        "pixel_deg": Key(
            float, "visual angle of the file's pixels", unit="deg", low=1e-4, high=10.0
        ),
    },
}


def check_background(
    table: Any,
    where: str,
    problems: list[str],
    folder: Path | None,
    *,
    display_max_cd_m2: float | None = None,
) -> dict | None:
    """A background table validated for its ``kind`` (an EXR's path must exist).

    Parameters
    ----------
    table
        The ``[background]`` table as read from TOML; its ``kind`` selects its keys in
        :data:`BACKGROUNDS`.
    where
        The table's dotted name in the messages (``'background'``).
    problems
        The list each problem found is appended to, one line naming the key and its value.
    folder
        The protocol file's folder, which an EXR's relative ``path`` is read from; ``None``:
        relative to the working folder.
    display_max_cd_m2
        The display's maximum luminance, cd/m²: a uniform field above it cannot be shown and
        is refused; ``None`` (default): not checked.

    Returns
    -------
    dict or None
        The validated table with its defaults, or ``None`` when it is not a table or its
        ``kind`` is unknown.
    """
    if not isinstance(table, Mapping):
        problems.append(f"{where} = {table!r}: must be a table with a kind")
        return None
    kind = table.get("kind")
    if kind not in BACKGROUNDS:
        problems.append(
            f"{where}.kind = {kind!r}: must be one of {', '.join(map(repr, BACKGROUNDS))}"
        )
        return None
    result = validate(table, BACKGROUNDS[kind], where, problems)
    if kind == "sky" and result.get("mean_cd_m2") is not None and result["mean_cd_m2"] <= 0:
        problems.append(
            f"{where}.mean_cd_m2 = {result['mean_cd_m2']!r}: must be above 0 cd/m² (the "
            "contrast is SD / mean)"
        )
    if kind == "sky" and result.get("cloud_min_deg") and result.get("cloud_max_deg"):
        if result["cloud_min_deg"] >= result["cloud_max_deg"]:
            problems.append(f"{where}.cloud_min_deg: must be below {where}.cloud_max_deg")
    if (
        kind == "uniform"
        and display_max_cd_m2 is not None
        and result.get("cd_m2") is not None
        and result["cd_m2"] > display_max_cd_m2
    ):
        problems.append(
            f"{where}.cd_m2 = {result['cd_m2']!r}: above what the display shows "
            f"(display.max_cd_m2 = {display_max_cd_m2!r}); must be in [0, {display_max_cd_m2:g}] "
            "cd/m²"
        )
    if kind == "exr" and result.get("path") is not None:
        path = Path(result["path"])
        if not path.is_absolute() and folder is not None:
            path = folder / path
        if not path.is_file():
            problems.append(f"{where}.path = {result['path']!r}: no such file ({path})")
    return result


# --- glare methods ---------------------------------------------------------------------------


def _glare_models() -> tuple[str, ...]:
    from glarelab.glare import GLARE_MODELS

    return tuple(GLARE_MODELS)


METHOD: Schema = {
    "name": Key(str, "the method's name in the data and the report", token=True),
    "title": Key(str, "the method's name in figures and text", default=""),
    "model": Key(str, "a glare model registered in glare.GLARE_MODELS (gaussian, vos, wave, …)"),
    "parameters": Key(
        dict,
        "the model's parameters (its constructor's keywords, but for an image array: wave's "
        "obstacle_image)",
        default={},
    ),
    "labels": LEVEL_LABELS,
    "levels_cd_m2": LEVELS_CD_M2,
}


def glare_model(model: str, parameters: Mapping[str, Any]):
    """The glare model ``model`` with ``parameters``; a table value builds the nested model
    of a parameter whose default is one (``hybrid``'s ``wave``).

    Parameters
    ----------
    model
        A name in :data:`glarelab.glare.GLARE_MODELS` (``'gaussian'``, ``'vos'``, ``'wave'``,
        ...).
    parameters
        The model's constructor keywords, in the units of its own parameters (a method's
        ``parameters`` table).

    Returns
    -------
    glarelab.glare.GlareModel
        The model.

    Raises
    ------
    ValueError, TypeError
        As :func:`glarelab.glare.make_model` raises them: an unknown model, an unknown
        parameter or a value out of range.
    """
    import dataclasses

    from glarelab.glare import GLARE_MODELS, make_model

    cls = GLARE_MODELS.get(model)
    values = dict(parameters)
    if cls is not None and dataclasses.is_dataclass(cls):
        for field in dataclasses.fields(cls):
            value = values.get(field.name)
            if isinstance(value, Mapping) and field.default_factory is not dataclasses.MISSING:
                nested = field.default_factory()
                if dataclasses.is_dataclass(nested):
                    keys = {f.name for f in dataclasses.fields(nested) if f.init}
                    unknown = sorted(set(value) - keys)
                    if unknown:  # named by key, not by the constructor's TypeError
                        raise ValueError(
                            f"{field.name}.{unknown[0]}: not a key of {field.name} (its keys: "
                            f"{', '.join(sorted(keys))})"
                        )
                    values[field.name] = type(nested)(**value)
    return make_model(model, **values)


def check_glare_model(
    model: Any,
    parameters: Any,
    where: str,
    problems: list[str],
    *,
    keys: tuple[str, str] = ("model", "parameters"),
) -> None:
    """The model exists and takes these parameters (its own checks name what is wrong).

    Parameters
    ----------
    model
        The method's ``model`` as read from TOML.
    parameters
        Its ``parameters`` table; ``None`` for none.
    where
        The method's dotted name in the messages (``'methods[0]'``).
    problems
        The list each problem found is appended to, one line naming the key and its value.
    keys
        The names of the model's and the parameters' keys in the messages; default
        ``('model', 'parameters')`` (a scene's are ``('glare_model', 'glare_parameters')``).
    """
    model_key, parameters_key = keys
    names = _glare_models()
    if model not in names:
        problems.append(
            f"{where}.{model_key} = {model!r}: must be one of {', '.join(map(repr, names))}"
        )
        return
    import dataclasses

    from glarelab.glare import GLARE_MODELS

    cls = GLARE_MODELS[model]
    if dataclasses.is_dataclass(cls) and isinstance(parameters, Mapping):
        allowed = [f.name for f in dataclasses.fields(cls) if f.init]
        unknown = [key for key in parameters if key not in allowed]
        if unknown:
            problems.append(
                f"{where}.{parameters_key}: {model!r} has no parameter "
                f"{', '.join(map(repr, unknown))}; its parameters are "
                f"{', '.join(allowed)}"
            )
            return
        arrays = [  # an image array (wave's obstacle_image): TOML holds none
            f.name for f in dataclasses.fields(cls) if f.init and "ndarray" in str(f.type)
        ]
        given = [key for key in arrays if parameters.get(key) is not None]
        if given:
            problems.append(
                f"{where}.{parameters_key}.{given[0]} = {parameters[given[0]]!r}: an image "
                "array, which a protocol cannot give (the Python API takes one, and the "
                "render and psf commands read one with --aperture-image); leave it out"
            )
            return
    try:
        glare_model(model, parameters or {})
    except TypeError as error:
        problems.append(f"{where}.{parameters_key}: {error}")
    except ValueError as error:
        problems.append(f"{where}.{parameters_key}: {error}")


def repeated_names(names: list) -> list:
    """The names that repeat, compared ignoring case (they become file names).

    Parameters
    ----------
    names
        The names to check (strings are compared case-folded, other values as they are).

    Returns
    -------
    list
        Each name that repeats, as written, sorted by its text; empty when none does.
    """
    folded = [n.casefold() if isinstance(n, str) else n for n in names]
    return sorted({n for n, f in zip(names, folded, strict=True) if folded.count(f) > 1}, key=str)


def check_methods(methods: list[dict] | None, where: str, problems: list[str]) -> None:
    """Glare methods: names unique, labels as many as levels, models and parameters valid.

    Parameters
    ----------
    methods
        The ``[[methods]]`` tables as :func:`~glarelab.protocols.keys.validate` returned them
        (:data:`METHOD`); ``None`` or empty is not checked.
    where
        Their name in the messages (``'methods'``).
    problems
        The list each problem found is appended to, one line naming the key and its value.
    """
    if not methods:
        return
    names = [m["name"] for m in methods if m.get("name")]
    repeated = repeated_names(names)
    if repeated:
        problems.append(
            f"{where}: method names repeat {repeated}: each must be different (ignoring case: "
            "they name files, and macOS's and Windows's file names ignore case)"
        )
    for i, method in enumerate(methods):
        at = f"{where}[{i}]"
        labels, levels = method.get("labels"), method.get("levels_cd_m2")
        if labels is not None and levels is not None and len(labels) != len(levels):
            problems.append(f"{at}: {len(labels)} labels for {len(levels)} levels_cd_m2")
        if method.get("model") is not None:
            check_glare_model(method["model"], method.get("parameters"), at, problems)


def display_pixel_deg(display: dict, distance_m: float) -> float:
    """Visual angle of one pixel of ``display`` (a protocol's validated ``[display]``) seen
    from ``distance_m``, degrees: from its pixel pitch, or its diagonal and resolution.

    Parameters
    ----------
    display
        The validated ``[display]`` table: ``resolution_px`` and one of ``pixel_pitch_mm``
        (mm) and ``diagonal_in`` (inches, square pixels assumed).
    distance_m
        Eye-screen distance, m, > 0.

    Returns
    -------
    float
        ``atan(pitch / distance)`` in degrees.

    Examples
    --------
    >>> display = {"resolution_px": [1920, 1080], "pixel_pitch_mm": 0.5}
    >>> round(display_pixel_deg(display, 1.0), 6)
    0.028648
    """
    width, height = display["resolution_px"]
    if display.get("pixel_pitch_mm") is not None:
        pitch_mm = display["pixel_pitch_mm"]
    else:
        pitch_mm = display["diagonal_in"] * 25.4 / math.hypot(width, height)
    return math.degrees(math.atan(pitch_mm / (distance_m * 1000.0)))
