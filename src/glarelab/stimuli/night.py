"""A night street with lamps, still or as a sequence, through the night-vision pipeline.

:func:`night_street` draws a procedural street at night in linear RGB (cd/m², channels of a
white of equal R, G, B), in the spirit of Spencer et al. 1995's Figure 14 (lamps and lit
windows in a dark street) and Luidolt 2020's test room (a lamp, coloured objects and fine
print in the dark): a sky, house fronts with lit and dark windows, a road with pools of light
under each lamp, coloured doors, cars and a hedge (what scotopic vision greys), and a poster of
fine stripes and print in the dark (what acuity loss blurs). Lamp bulbs are small disks at
``lamp_cd_m2``; the road under a lamp is lit to :data:`POOL_FRACTION` of it (1 cd/m² under a
2e4 cd/m² bulb, as a lit road at night) and lit windows are :data:`WINDOW_FRACTION` of it.

:func:`night_sequence` gives the frames, the frame time and the gaze of what a study shows:

- ``'still'``: one frame, the eye adapted to it;
- ``'enter_dark'``: the same frame over time, the eye adapted to ``start_cd_m2`` before (the
  lit room it left; Luidolt §5.1, eqs. 5.2-5.4);
- ``'gaze'``: the gaze moves from the road between the first two pools of light to the
  first lamp and back (the view-dependent window of §5.1).

:func:`build_night` renders a rating protocol's scene once per condition with
:func:`glarelab.glare.render_night` (the effects the condition names) for a stimulus set.

References
----------
Spencer, G. et al. (1995). Physically-based glare effects for digital images. SIGGRAPH, §5,
Fig. 14. Luidolt, L. (2020). Perception of light in virtual reality. TU Wien, ch. 5, §7.1.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np

from glarelab import glare
from glarelab.files.values import check_generator
from glarelab.glare._validation import check_choice, check_in_range, check_positive
from glarelab.protocols import Protocol
from glarelab.protocols import pixel_deg as display_pixel_deg
from glarelab.protocols.rating import scene_glare_model
from glarelab.stimuli.kernels import KernelUse
from glarelab.stimuli.preview import to_display
from glarelab.stimuli.shapes import ImageRow

__all__ = [
    "SEQUENCES",
    "build_night",
    "night_kernels",
    "night_plan",
    "night_row",
    "night_scene",
    "night_sequence",
    "night_street",
    "preview_strip",
    "shows_scene",
]

SEQUENCES = ("still", "enter_dark", "gaze")
LAMP_RGB = np.array([1.0, 0.85, 0.6])  # a warm white bulb (sodium-like lamps are yellower)
WINDOW_RGB = np.array([1.0, 0.75, 0.45])  # incandescent light behind curtains
SKY_RGB = np.array([0.55, 0.7, 1.0])  # a bluish night sky
OBJECT_RGB = {  # coloured things under the lamps: what rod vision greys (Spencer §5)
    "red car": np.array([0.8, 0.06, 0.05]),
    "blue door": np.array([0.06, 0.15, 0.75]),
    "green hedge": np.array([0.08, 0.45, 0.1]),
    "yellow door": np.array([0.8, 0.65, 0.08]),
}
PREVIEW_FRAMES = 4  # frames of a sequence in its preview strip
POOL_FRACTION = 5e-5  # the road under a lamp: 1 cd/m² under a 2e4 cd/m² bulb (a lit street)
WINDOW_FRACTION = 2e-4  # a lit window: 4 cd/m² beside a 2e4 cd/m² bulb


def _disk(yy, xx, cy, cx, radius) -> np.ndarray:
    """Area fraction of a disk in each pixel (4 × 4 samples per pixel)."""
    fraction = np.zeros(yy.shape)
    for oy in (-0.375, -0.125, 0.125, 0.375):
        for ox in (-0.375, -0.125, 0.125, 0.375):
            fraction += (yy + oy - cy) ** 2 + (xx + ox - cx) ** 2 <= radius**2
    return fraction / 16.0


def night_street(
    size_px: tuple[int, int],
    *,
    pixel_deg: float,
    lamps: int = 3,
    lamp_cd_m2: float = 2e4,
    ambient_cd_m2: float = 0.02,
    rng: np.random.Generator,
) -> dict:
    """A procedural street at night, linear RGB in cd/m².

    Parameters
    ----------
    size_px
        ``(width, height)`` in pixels, each 16-4096.
    pixel_deg
        Visual angle of a pixel, degrees, > 0: sets the size of the bulbs (0.25° across, a
        lamp some 10 m away) and of the poster's stripes (2 and 6 cycles/deg).
    lamps
        Street lamps along the street, 1-12; default 3.
    lamp_cd_m2
        Luminance of a bulb, cd/m², > 0; default 2e4.
    ambient_cd_m2
        Luminance of the sky and unlit walls, cd/m², >= 0; default 0.02 (mesopic).
    rng
        Random details (which windows are lit, the road's texture).

    Returns
    -------
    dict
        ``img`` (``(H, W, 3)`` float64, cd/m²), ``lamps_px`` (``(row, column)`` of each bulb),
        ``poster_px`` (its centre) and the parameters.

    Raises
    ------
    ValueError
        For a size, pixel size, number or luminance out of range, each named, or an
        ``rng`` that is not a generator.

    Examples
    --------
    >>> street = night_street((96, 64), pixel_deg=0.1, rng=np.random.default_rng(0))
    >>> street["img"].shape, round(float(street["img"].max())), len(street["lamps_px"])
    ((64, 96, 3), 20000, 3)
    """
    if (
        not isinstance(size_px, tuple | list)
        or len(size_px) != 2
        or not all(isinstance(v, int | np.integer) and 16 <= v <= 4096 for v in size_px)
    ):
        raise ValueError(f"size_px must be (width, height), each 16-4096 pixels; got {size_px!r}")
    pixel_deg = check_positive("pixel_deg", pixel_deg, unit="deg")
    check_generator(rng)
    if isinstance(lamps, bool) or not isinstance(lamps, int | np.integer) or not 1 <= lamps <= 12:
        raise ValueError(f"lamps must be a whole number from 1 to 12; got {lamps!r}")
    lamp = check_in_range("lamp_cd_m2", lamp_cd_m2, 0.0, 1e9, unit="cd/m²", low_inclusive=False)
    ambient = check_in_range("ambient_cd_m2", ambient_cd_m2, 0.0, 1e3, unit="cd/m²")
    width, height = int(size_px[0]), int(size_px[1])
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float64)
    horizon = 0.55 * height  # the road below, the houses above
    img = np.zeros((height, width, 3))
    # the sky: brightest at the horizon, with the ambient luminance on average
    sky = ambient * (0.6 + 0.8 * np.clip(yy / horizon, 0.0, 1.0))[..., None] * SKY_RGB
    roofline = 0.18 * height + 0.08 * height * (np.floor(xx / (width / 5)) % 2)
    img[:] = sky
    houses = (yy >= roofline) & (yy < horizon)
    img[houses] = 0.5 * ambient
    # windows: a grid on the fronts, a third of them lit
    cell_w, cell_h = max(width / 14, 3.0), max(height / 12, 3.0)
    col, row = np.floor(xx / cell_w), np.floor((yy - roofline) / cell_h)
    in_cell = ((xx % cell_w) > 0.3 * cell_w) & (((yy - roofline) % cell_h) > 0.35 * cell_h)
    lit_cells = rng.random((int(height / cell_h) + 3, int(width / cell_w) + 3)) < 0.33
    lit = lit_cells[np.clip(row.astype(int), 0, lit_cells.shape[0] - 1), col.astype(int)]
    window = houses & in_cell & (yy < horizon - 0.35 * cell_h)
    img[window & lit] = WINDOW_FRACTION * lamp * WINDOW_RGB
    img[window & ~lit] = 0.2 * ambient
    # the road, with a faint texture
    road = yy >= horizon
    texture = 1.0 + 0.3 * (rng.random((height, width)) - 0.5)
    img[road] = (0.3 * ambient * texture[road])[:, None]
    # lamps: poles, bulbs, and pools of light on the road and the fronts below them
    bulb_radius = max(0.125 / pixel_deg, 0.6)
    columns = (np.arange(lamps) + 0.5) * width / lamps
    lamps_px = []
    for index, cx in enumerate(columns):
        cy = horizon - (0.3 - 0.05 * (index % 2)) * height
        pole = (np.abs(xx - cx) <= max(0.004 * width, 0.5)) & (yy > cy) & (yy < horizon + 4)
        img[pole] = 0.1 * ambient
        across = (xx - cx) / (0.12 * width)
        along = (yy - (horizon + 0.15 * height)) / (0.1 * height)
        pool = np.exp(-(across**2) - along**2)
        glow = POOL_FRACTION * lamp * pool * (yy > cy)
        img += glow[..., None] * LAMP_RGB * np.where(road | houses, 1.0, 0.0)[..., None]
        cover = _disk(yy, xx, cy, cx, bulb_radius)[..., None]
        img = img * (1.0 - cover) + cover * lamp * LAMP_RGB
        lamps_px.append((float(cy), float(cx)))
    # coloured objects in the pools of light: doors on the fronts, a car and a hedge on the road
    for index, (name, rgb) in enumerate(OBJECT_RGB.items()):
        cx = (index + 0.7) * width / (len(OBJECT_RGB) + 0.4)
        if "door" in name:
            box = (
                (np.abs(xx - cx) < 0.025 * width) & (yy > horizon - 0.12 * height) & (yy < horizon)
            )
        else:
            box = (
                (np.abs(xx - cx) < 0.07 * width)
                & (yy > horizon + 0.05 * height)
                & (yy < horizon + 0.14 * height)
            )
        light = POOL_FRACTION * lamp + ambient  # lit by the lamps
        img[box] = light * rgb
    # a poster of fine stripes and print in the dark, between two lamps
    py, px = horizon - 0.2 * height, 0.5 * width / lamps if lamps > 1 else 0.2 * width
    half_w, half_h = 0.05 * width, 0.06 * height
    poster = (np.abs(xx - px) < half_w) & (np.abs(yy - py) < half_h)
    stripes = np.where(xx < px, 2.0, 6.0)  # cycles/deg: resolved in daylight, lost at night
    grating = 0.5 + 0.5 * np.sign(np.sin(2 * math.pi * stripes * (xx - px) * pixel_deg))
    img[poster] = ((2.0 * ambient + 1e-3) * (0.2 + 0.8 * grating[poster]))[:, None]
    return {
        "img": np.clip(img, 0.0, None),
        "lamps_px": lamps_px,
        "poster_px": (float(py), float(px)),
        "size_px": [width, height],
        "pixel_deg": pixel_deg,
        "lamps": int(lamps),
        "lamp_cd_m2": lamp,
        "ambient_cd_m2": ambient,
    }


def night_sequence(
    street: dict,
    sequence: Literal["still", "enter_dark", "gaze"],
    *,
    seconds: float,
    frame_rate_hz: float,
    start_cd_m2: float = 100.0,
) -> dict:
    """The frames of a night scene as a study shows them, with their times and gaze.

    Parameters
    ----------
    street
        A :func:`night_street`.
    sequence
        ``'still'``, ``'enter_dark'`` or ``'gaze'`` (see the module notes).
    seconds
        How long it is shown, s, > 0.
    frame_rate_hz
        Frames per second of a sequence, > 0 (a still has one frame).
    start_cd_m2
        ``'enter_dark'``: the adapted luminance before the first frame, cd/m², >= 0.

    Returns
    -------
    dict
        ``frames`` (list of images), ``frame_time_s``, ``gaze_px`` (one ``(row, column)`` per
        frame, or None), ``initial_adaptation_cd_m2`` (or None).

    Raises
    ------
    ValueError
        For a ``street`` that is not a :func:`night_street` scene, an unknown ``sequence``,
        or a time, rate or luminance out of its range.

    Examples
    --------
    >>> street = night_street((64, 48), pixel_deg=0.1, rng=np.random.default_rng(0))
    >>> seq = night_sequence(street, "gaze", seconds=1.0, frame_rate_hz=4.0)
    >>> len(seq["frames"]), seq["frame_time_s"], seq["gaze_px"][2] == street["lamps_px"][0]
    (4, 0.25, True)
    """
    check_choice("sequence", sequence, SEQUENCES)
    seconds = check_positive("seconds", seconds, unit="s")
    rate = check_positive("frame_rate_hz", frame_rate_hz, unit="Hz")
    start = check_in_range("start_cd_m2", start_cd_m2, 0.0, 1e9, unit="cd/m²")
    if not (isinstance(street, dict) and {"img", "lamps_px"} <= street.keys()):
        raise ValueError(
            "street must be a night_street() scene (a dict with 'img' and 'lamps_px'); got "
            f"{type(street).__name__}"
            + (f" with keys {sorted(street)}" if isinstance(street, dict) else "")
        )
    img = street["img"]
    if sequence == "still":
        return {
            "frames": [img],
            "frame_time_s": seconds,
            "gaze_px": None,
            "initial_adaptation_cd_m2": None,
        }
    n = max(round(seconds * rate), 1)
    if sequence == "enter_dark":
        return {
            "frames": [img] * n,
            "frame_time_s": 1.0 / rate,
            "gaze_px": None,
            "initial_adaptation_cd_m2": start,
        }
    elif sequence == "gaze":
        height, width = img.shape[:2]
        lamps = street["lamps_px"]
        between = width / len(lamps) if len(lamps) > 1 else 0.05 * width
        dark = (0.95 * height, between)  # the road's edge between the first two pools of light
        lamp = lamps[0]
        # to the lamp by the middle frame (n // 2), back by the last
        middle = n // 2
        steps = np.arange(n, dtype=float)
        back = (n - 1 - steps) / max(n - 1 - middle, 1)  # after the middle frame
        phase = np.where(steps <= middle, steps / max(middle, 1), back) if n > 1 else np.ones(1)
        gaze = [((1 - p) * dark[0] + p * lamp[0], (1 - p) * dark[1] + p * lamp[1]) for p in phase]
        return {
            "frames": [img] * n,
            "frame_time_s": 1.0 / rate,
            "gaze_px": gaze,
            "initial_adaptation_cd_m2": None,
        }
    else:
        raise ValueError(f"sequence must be one of {', '.join(SEQUENCES)}; got {sequence!r}")


def preview_strip(frames: list[np.ndarray], *, l_dmax_cd_m2: float) -> np.ndarray:
    """8-bit sRGB previews of up to :data:`PREVIEW_FRAMES` frames (first, …, last), side by
    side with a 4-pixel gap: what a report shows of a stimulus.

    Parameters
    ----------
    frames
        The frames, linear display RGB, cd/m², ``(H, W, 3)`` each; evenly spaced ones are
        shown.
    l_dmax_cd_m2
        The luminance shown as white, cd/m² (the display's maximum).

    Returns
    -------
    numpy.ndarray
        uint8 ``(H, n × W + 4 (n - 1), 3)``.

    Raises
    ------
    ValueError
        For no frames.
    """
    if not (isinstance(frames, list | tuple) and len(frames) > 0):
        raise ValueError(f"frames must be a non-empty list of frames; got {frames!r:.60}")
    count = min(len(frames), PREVIEW_FRAMES)
    picks = np.unique(np.round(np.linspace(0, len(frames) - 1, count)).astype(int))
    tiles = [to_display(frames[i], l_dmax_cd_m2=l_dmax_cd_m2) for i in picks]
    gap = np.full((tiles[0].shape[0], 4, 3), 255, dtype=np.uint8)
    parts = [tiles[0]]
    for tile in tiles[1:]:
        parts += [gap, tile]
    return np.concatenate(parts, axis=1)


def night_plan(protocol: Protocol, refresh_hz: float) -> dict:
    """What a session shows of each condition at ``refresh_hz``: its frame names (as
    :func:`build_night` names them) and the refreshes of each (a whole number, at least 1).

    Parameters
    ----------
    protocol
        A rating protocol with a ``[scene]``.
    refresh_hz
        The display's refresh rate, Hz, > 0.

    Returns
    -------
    dict
        Condition name → ``frames`` (names), ``refreshes_per_frame`` (the refreshes each frame
        stays on: the scene's ``seconds`` for a still, the refresh over the scene's frame rate
        for a sequence, rounded) and ``refreshes`` (in all).

    Raises
    ------
    ValueError
        If ``refresh_hz`` is not a positive number.

    Examples
    --------
    >>> from glarelab.protocols import load_protocol
    >>> plan = night_plan(load_protocol("night2026"), 60.0)
    >>> first = plan["full"]
    >>> len(first["frames"]), first["frames"][0], first["refreshes_per_frame"], first["refreshes"]
    (30, 'full_f000', 6, 180)
    """
    scene = protocol["scene"]
    refresh = check_positive("refresh_hz", refresh_hz, unit="Hz")
    if scene["sequence"] == "still":
        n, per_frame = 1, max(round(scene["seconds"] * refresh), 1)
    else:
        n = max(round(scene["seconds"] * scene["frame_rate_hz"]), 1)
        per_frame = max(round(refresh / scene["frame_rate_hz"]), 1)
    return {
        c["name"]: {
            "frames": [f"{c['name']}_f{i:03d}" for i in range(n)],
            "refreshes_per_frame": per_frame,
            "refreshes": per_frame * n,
        }
        for c in protocol["conditions"]
    }


def build_night(protocol: Protocol, *, progress=None) -> dict:
    """Render a rating protocol's night scene once per condition.

    Each condition's frames are :func:`glarelab.glare.render_night` of the scene's sequence with
    the condition's effects (display RGB, cd/m²), named ``CONDITION_fNNN``; its preview strip is
    ``preview_CONDITION.png``.

    Parameters
    ----------
    protocol
        A validated rating protocol with a ``[scene]``.
    progress
        Optional callable ``progress(done, total, what)``, called after each image or
        condition (:func:`glarelab.stimuli.stimulus_set.progress_bar`); default ``None``: none.

    Returns
    -------
    dict
        ``images`` (name → ``img`` and parameters), ``geometry``, ``parameters``,
        ``previews`` (file name → 8-bit RGB array) and ``sequences`` (condition → frame names
        and refreshes per frame).
    """
    scene = protocol["scene"]
    display = protocol["display"]
    street = night_scene(protocol)
    pixel = street["pixel_deg"]
    shown = night_sequence(
        street,
        scene["sequence"],
        seconds=scene["seconds"],
        frame_rate_hz=scene["frame_rate_hz"],
        start_cd_m2=scene["start_cd_m2"],
    )
    n = len(shown["frames"])
    plan = night_plan(protocol, display["refresh_hz"])
    model = None
    if any("glare" in c["effects"] for c in protocol["conditions"]):
        model = scene_glare_model(scene)  # its halo's options taken; frames set the eye
    images, previews, sequences, rendered = {}, {}, {}, {}
    conditions = protocol["conditions"]
    for index, condition in enumerate(conditions, start=1):
        effects = tuple(e for e in glare.night.EFFECTS if e in condition["effects"])
        if effects not in rendered:  # two conditions of one pipeline share its rendering
            # the options of the effects the condition keeps (render_night refuses the others)
            adapting = (
                {
                    "frame_time_s": shown["frame_time_s"] if n > 1 else None,
                    "initial_adaptation_cd_m2": shown["initial_adaptation_cd_m2"],
                }
                if "adaptation" in effects
                else {}
            )
            night = glare.render_night(
                shown["frames"] if n > 1 else shown["frames"][0],
                pixel_deg=pixel,
                effects=effects,
                glare_model=model if "glare" in effects else None,
                display_max_cd_m2=display["max_cd_m2"],
                adapted_display_cd_m2=min(scene["adapted_display_cd_m2"], display["max_cd_m2"]),
                gaze_px=shown["gaze_px"],
                **adapting,
            )
            rendered[effects] = night
        night = rendered[effects]
        frames = night.frames if isinstance(night.frames, list) else [night.frames]
        names = plan[condition["name"]]["frames"]
        for number, (name, frame) in enumerate(zip(names, frames, strict=True)):
            images[name] = {
                "img": np.asarray(frame, dtype=np.float64),
                "kind": "night",
                "condition": condition["name"],
                "frame": number,
                "effects": list(effects),
                "refreshes": plan[condition["name"]]["refreshes_per_frame"],
                "target_cd_m2": float(night.targets_cd_m2[number]),
                "adaptation_cd_m2": float(night.adaptation_cd_m2[number]),
                "pupil_mm": None
                if math.isnan(night.pupil_mm[number])
                else float(night.pupil_mm[number]),
            }
        sequences[condition["name"]] = plan[condition["name"]]
        previews[f"preview_{condition['name']}.png"] = preview_strip(
            frames, l_dmax_cd_m2=display["max_cd_m2"]
        )
        if progress is not None:
            progress(index, len(conditions), f"condition {condition['name']}")
    return {
        "images": images,
        "geometry": {
            "pixel_deg": pixel,
            "size_px": list(scene["size_px"]),
            "lamps_px": street["lamps_px"],
            "poster_px": list(street["poster_px"]),
            "gap_px": 0,
        },
        "parameters": {
            "scene": dict(scene),
            "frame_time_s": shown["frame_time_s"],
            "gaze_px": shown["gaze_px"],
            "initial_adaptation_cd_m2": shown["initial_adaptation_cd_m2"],
            "sequences": sequences,
        },
        "previews": previews,
    }


def shows_scene(protocol: Protocol) -> bool:
    """Whether a rating protocol shows a scene from a stimulus set (a questionnaire alone shows
    no images; a live scene is rendered in the session, per refresh, and has no set).

    Parameters
    ----------
    protocol
        A validated rating protocol.

    Returns
    -------
    bool
        Whether it has a ``[scene]`` that is not ``live``.
    """
    scene = protocol.data.get("scene")
    return scene is not None and not scene.get("live", False)


def night_scene(protocol: Protocol) -> dict:
    """The protocol's night street (:func:`night_street` of its ``[scene]``, seeded by the
    protocol's and the scene's seeds), as a stimulus set and a live session both render it.

    Parameters
    ----------
    protocol
        A validated rating protocol with a ``[scene]``.

    Returns
    -------
    dict
        :func:`night_street`'s dict (``img`` in cd/m², ``pixel_deg``...).
    """
    scene = protocol["scene"]
    pixel = scene["pixel_deg"] or display_pixel_deg(protocol)
    return night_street(
        tuple(scene["size_px"]),
        pixel_deg=pixel,
        lamps=scene["lamps"],
        lamp_cd_m2=scene["lamp_cd_m2"],
        ambient_cd_m2=scene["ambient_cd_m2"],
        rng=np.random.default_rng([protocol.seed, scene["seed"]]),
    )


def night_kernels(protocol: Protocol) -> list[KernelUse]:
    """The glare kernels a live scene's bank digitises before its first frame: the scene's
    glare model at each pupil of the bank (:func:`glarelab.glare.night.live.pupil_bank_mm`),
    over the scene at its pixel angle; none for a scene a stimulus set renders (its night
    pipeline plans its kernels per frame, from the adaptation) or without a scene.

    Parameters
    ----------
    protocol
        A validated protocol of the rating paradigm.

    Returns
    -------
    list of glarelab.stimuli.kernels.KernelUse
        Named ``scene.glare_model``, with the bank's pupil.

    Examples
    --------
    >>> from glarelab.protocols import load_protocol
    >>> uses = night_kernels(load_protocol("luidolt2020-live"))
    >>> uses[0].where, uses[0].shape
    ("scene.glare_model (the bank's 2 mm pupil)", (799, 1279))
    >>> night_kernels(load_protocol("night2026"))
    []
    """
    from glarelab.glare.models.digitise import kernel_shape_for
    from glarelab.glare.night.live import pupil_bank_mm
    from glarelab.glare.night.pipeline import eye_state_model, has_eye_field

    scene = protocol.data.get("scene")
    if not scene or not scene["live"]:
        return []
    model = scene_glare_model(scene)
    pixel = scene["pixel_deg"] or display_pixel_deg(protocol)
    width, height = scene["size_px"]
    shape = kernel_shape_for((height, width))  # the renderer's of the scene
    if not has_eye_field(model, "pupil_mm"):  # one model for every pupil
        return [KernelUse("scene.glare_model", model, pixel, shape)]
    return [
        KernelUse(
            f"scene.glare_model (the bank's {pupil:g} mm pupil)",
            eye_state_model(model, pupil_mm=float(pupil), regime=None),
            pixel,
            shape,
        )
        for pupil in pupil_bank_mm(model)
    ]


def night_row(protocol: Protocol, display_pixel_deg: float) -> ImageRow | None:
    """The scene, alone, at the protocol's own pixel angle; None without a scene.

    Parameters
    ----------
    protocol
        A validated protocol of the paradigm.
    display_pixel_deg
        Visual angle of one pixel of the display the session runs on, degrees. Not used:
        the scene is drawn at its own ``pixel_deg``, one image pixel on one display pixel.

    Returns
    -------
    ImageRow or None
        The scene's ``size_px``, or None when the protocol shows no scene.
    """
    scene = protocol.data.get("scene")
    if scene is None:
        return None
    return ImageRow([tuple(scene["size_px"])], 0, scene["pixel_deg"])
