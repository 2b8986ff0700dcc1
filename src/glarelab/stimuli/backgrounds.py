"""Backgrounds a protocol can put behind its stimulus, by ``kind``:

- ``sky``: the procedural cloudy sky of :mod:`glarelab.stimuli.sky` (Yoshida et al. 2008 used a
  photograph of a cloudy sky that is not available);
- ``uniform``: a field of one luminance (Spencer et al. 1995: "a black field");
- ``lamp``: a desk lamp on a desk in a dark room, drawn procedurally (Spencer §4's context
  photograph is not available), the bulb at the centre;
- ``exr``: a linear luminance EXR of the lab's own (cd/m²), at its own pixel size: cut from
  its centre, at the stimulus's pixel size as it is, else read at the centre of each of the
  stimulus's pixels (bilinear, luminance kept); it must cover every pixel centre.

Each paradigm says which backgrounds its builder draws (:class:`BackgroundField`: the protocol's
table, the field it fills, the ceiling), so ``glarelab protocol check`` refuses what a build
would (:func:`check_backgrounds`) before anything is rendered.

Every background is a luminance image in cd/m², drawn from the protocol's seed where it is
random.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy import ndimage

from glarelab.files.values import check_generator
from glarelab.glare._validation import check_in_range
from glarelab.stimuli.exr import read_exr
from glarelab.stimuli.sky import cloudy_sky

__all__ = ["ROOM_CD_M2", "BackgroundField", "background", "check_backgrounds", "lamp_scene"]

ROOM_CD_M2 = 0.05  # a darkened room (Spencer §4)


@dataclass(frozen=True)
class BackgroundField:
    """A background a paradigm's builder draws.

    Attributes
    ----------
    where
        The protocol's key of its table, for messages (``'background'``,
        ``'contexts[1].background'``).
    spec
        The validated table (``kind`` and its keys).
    shape
        (height, width) of the field it fills, pixels.
    pixel_deg
        Visual angle of the field's pixels, degrees.
    ceiling_cd_m2
        What no background pixel may exceed, cd/m² (see :func:`background`).
    """

    where: str
    spec: dict
    shape: tuple[int, int]
    pixel_deg: float
    ceiling_cd_m2: float


def check_backgrounds(
    fields: Sequence[BackgroundField], *, seed: int, folder: Path | None = None
) -> list[str]:
    """What a build would refuse of a protocol's backgrounds, each drawn as its builder draws
    it (one generator from ``seed``, in order): an EXR that cannot be read, that holds values
    that are not luminances, that does not cover the field, or that is above the ceiling; a
    sky whose contrast the ceiling cuts.

    Parameters
    ----------
    fields
        The paradigm's backgrounds (its stimuli entry's ``backgrounds(protocol)``).
    seed
        The protocol's seed.
    folder
        Where a relative EXR path is found (the protocol's folder); default None: the working
        folder.

    Returns
    -------
    list of str
        One line per background refused, naming its key; empty when a build would draw all.

    Examples
    --------
    >>> field = BackgroundField("background", {"kind": "uniform", "cd_m2": 500.0}, (4, 4),
    ...                         0.1, 220.0)
    >>> check_backgrounds([field], seed=0)
    ['background: the uniform background reaches 500 cd/m², above 220 cd/m² where glare is added: it would glare itself']
    """  # noqa: E501
    rng = np.random.default_rng(seed)
    problems = []
    for field_ in fields:
        try:
            background(
                field_.spec,
                field_.shape,
                pixel_deg=field_.pixel_deg,
                rng=rng,
                ceiling_cd_m2=field_.ceiling_cd_m2,
                folder=folder,
            )
        except (ValueError, OSError) as error:
            text = str(error)
            if text.startswith("background."):  # a key of the table: named under its own
                problems.append(f"{field_.where}.{text.removeprefix('background.')}")
            else:
                problems.append(f"{field_.where}: {text}")
    return problems


def background(
    spec: dict,
    shape: tuple[int, int],
    *,
    pixel_deg: float,
    rng: np.random.Generator,
    ceiling_cd_m2: float,
    folder: Path | None = None,
) -> np.ndarray:
    """The background ``spec`` (a validated protocol table) as an image of ``shape`` pixels.

    Parameters
    ----------
    spec
        ``kind`` and its keys (:data:`glarelab.protocols.common.BACKGROUNDS`).
    shape
        (height, width) in pixels.
    pixel_deg
        Visual angle of a pixel, degrees.
    rng
        Randomness of procedural backgrounds.
    ceiling_cd_m2
        Nothing in the background may exceed this (it would glare itself); the sky is kept
        under it, other kinds are refused above it.
    folder
        Where a relative EXR path is found (the protocol's folder).

    Raises
    ------
    ValueError
        For an unknown kind, an EXR too small for the stimulus, or a background above the
        ceiling.
    """
    kind = spec["kind"]
    if kind == "sky":
        if spec["cloud_max_deg"] < 2 * pixel_deg:  # no frequency of the band is drawn
            raise ValueError(
                f"background.cloud_max_deg = {spec['cloud_max_deg']:g}° is under two pixels "
                f"({2 * pixel_deg:.4g}° at {pixel_deg:.4g}°/px): no cloud of that size can be "
                "drawn; give clouds of at least two pixels"
            )
        try:
            image = cloudy_sky(
                shape,
                pixel_deg=pixel_deg,
                rng=rng,
                mean_cd_m2=spec["mean_cd_m2"],
                contrast=spec["contrast"],
                cloud_min_deg=spec["cloud_min_deg"],
                cloud_max_deg=spec["cloud_max_deg"],
                slope=spec["spectrum_slope"],
                ceiling_cd_m2=0.98 * ceiling_cd_m2,
            )
        except ValueError as error:  # named by the protocol's key
            raise ValueError(f"background.{error}") from None
    elif kind == "uniform":
        if not (np.isfinite(spec["cd_m2"]) and spec["cd_m2"] >= 0):
            raise ValueError(f"a uniform background's cd_m2 must be >= 0; got {spec['cd_m2']!r}")
        image = np.full(shape, float(spec["cd_m2"]))
    elif kind == "lamp":
        if shape[0] != shape[1]:
            raise ValueError(f"a lamp scene is square; shape {shape} is not")
        image = lamp_scene(shape[0], rng=rng, peak_cd_m2=spec["peak_cd_m2"])["img"]
    elif kind == "exr":
        image = _from_exr(spec, shape, pixel_deg=pixel_deg, folder=folder)
    else:
        raise ValueError(f"background kind must be sky, uniform, lamp or exr; got {kind!r}")
    if kind != "sky" and float(image.max(initial=0.0)) > ceiling_cd_m2:
        raise ValueError(
            f"the {kind} background reaches {float(image.max()):.4g} cd/m², above "
            f"{ceiling_cd_m2:g} cd/m² where glare is added: it would glare itself"
        )
    return image


def _from_exr(spec: dict, shape: tuple[int, int], *, pixel_deg: float, folder) -> np.ndarray:
    path = Path(spec["path"])
    if not path.is_absolute() and folder is not None:
        path = Path(folder) / path
    image = read_exr(path).astype(np.float64)
    if image.ndim == 3:  # linear RGB: its luminance (ITU-R BT.709)
        image = image @ np.array([0.2126, 0.7152, 0.0722])
    if not np.isfinite(image).all() or image.min() < 0:
        raise ValueError(f"{path}: a background needs finite luminances >= 0 cd/m²")
    file_deg = spec["pixel_deg"]
    height, width = shape
    same = np.isclose(file_deg, pixel_deg, rtol=1e-6)
    # each of the stimulus's pixel centres in the file's pixel coordinates, the centres aligned
    rows, columns = (
        (np.arange(n) - (n - 1) / 2) * pixel_deg / file_deg + (have - 1) / 2
        for n, have in zip(shape, image.shape, strict=True)
    )
    reach = 0.5 + 1e-9  # a file's pixel covers half a pixel on each side of its centre
    if (image.shape[0] < height or image.shape[1] < width) if same else (
        rows[0] < -reach or rows[-1] > image.shape[0] - 1 + reach
        or columns[0] < -reach or columns[-1] > image.shape[1] - 1 + reach
    ):  # fmt: skip
        raise ValueError(
            f"{path} covers {image.shape[1] * file_deg:.6g}° × {image.shape[0] * file_deg:.6g}° "
            f"({image.shape[1]} × {image.shape[0]} pixels of background.pixel_deg = "
            f"{file_deg:g}°); the stimulus needs {width * pixel_deg:.6g}° × "
            f"{height * pixel_deg:.6g}° ({width} × {height} pixels of {pixel_deg:.6g}°): "
            "give a larger image, or its true pixel size"
        )
    if same:  # cut from the centre as it is
        top, left = (image.shape[0] - height) // 2, (image.shape[1] - width) // 2
        return image[top : top + height, left : left + width].copy()
    grid = np.meshgrid(rows, columns, indexing="ij")
    return ndimage.map_coordinates(image, grid, order=1, mode="nearest")  # bilinear


def _polygon_mask(shape: tuple[int, int], vertices: list[tuple[float, float]]) -> np.ndarray:
    """Pixels whose centres are inside a convex polygon (vertices as (x, y) in px)."""
    y, x = np.indices(shape) + 0.5
    inside = np.ones(shape, dtype=bool)
    n = len(vertices)
    area = sum(
        vertices[i][0] * vertices[(i + 1) % n][1] - vertices[(i + 1) % n][0] * vertices[i][1]
        for i in range(n)
    )
    sign = 1.0 if area > 0 else -1.0
    for i in range(n):
        (x0, y0), (x1, y1) = vertices[i], vertices[(i + 1) % n]
        inside &= sign * ((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0)) >= 0
    return inside


def lamp_scene(size: int, *, rng: np.random.Generator, peak_cd_m2: float) -> dict:
    """A desk lamp on a desk in a dark room, the bulb at the window centre.

    Returns ``img`` (cd/m², the bulb region dark: the source is added separately), and masks
    ``desk``, ``lamp``. Luminances stay below 15 % of ``peak_cd_m2``.

    Parameters
    ----------
    size
        Side of the square window, pixels.
    rng
        The random generator of the desk's grain (the protocol's seed).
    peak_cd_m2
        The scene's scale, cd/m²: the desk is lit at about 2 % of it, and no surface reaches
        15 %.

    Returns
    -------
    dict
        ``img``: ``(size, size)`` luminance, cd/m²; ``desk`` and ``lamp``: boolean masks of
        the same shape.

    Raises
    ------
    ValueError
        For an ``rng`` that is not a generator, or ``peak_cd_m2`` not in (0, 1e9].
    """
    check_generator(rng)
    check_in_range("peak_cd_m2", peak_cd_m2, 0.0, 1e9, unit="cd/m²", low_inclusive=False)
    img = np.full((size, size), ROOM_CD_M2)
    c = size / 2
    y, x = np.indices((size, size)) + 0.5
    # desk top: a trapezoid in perspective over the lower part of the window
    desk = _polygon_mask(
        (size, size),
        [
            (0.02 * size, size),
            (0.98 * size, size),
            (0.85 * size, 0.68 * size),
            (0.15 * size, 0.68 * size),
        ],
    )
    grain = 1.0 + 0.12 * np.sin(2 * np.pi * (y / (0.035 * size) + 0.6 * np.sin(x / (0.2 * size))))
    grain *= 1.0 + 0.05 * rng.standard_normal((size, size))
    light_pool = np.exp(-(((x - c) / (0.3 * size)) ** 2 + ((y - 0.8 * size) / (0.12 * size)) ** 2))
    desk_l = 0.02 * peak_cd_m2 * grain * (0.2 + light_pool)
    img = np.where(desk, desk_l, img)
    # lamp: base on the desk, an arm up to the shade, the shade opening down at the centre
    base = ((x - 0.7 * size) / (0.1 * size)) ** 2 + ((y - 0.8 * size) / (0.03 * size)) ** 2 <= 1
    arm_a, arm_b = np.array([0.7 * size, 0.79 * size]), np.array([0.62 * size, 0.42 * size])
    arm_c = np.array([c + 0.04 * size, c - 0.06 * size])
    arm = np.zeros((size, size), dtype=bool)
    for a, b in ((arm_a, arm_b), (arm_b, arm_c)):
        ab = b - a
        h = np.clip(((x - a[0]) * ab[0] + (y - a[1]) * ab[1]) / (ab @ ab), 0, 1)
        arm |= np.hypot(x - a[0] - h * ab[0], y - a[1] - h * ab[1]) <= 0.012 * size
    shade = _polygon_mask(
        (size, size),
        [
            (c - 0.1 * size, c - 0.005 * size),
            (c + 0.1 * size, c - 0.005 * size),
            (c + 0.045 * size, c - 0.12 * size),
            (c - 0.045 * size, c - 0.12 * size),
        ],
    )
    lamp = base | arm | shade
    metal = 0.004 * peak_cd_m2 * (1.0 + 0.6 * np.clip((c - y) / size + 0.5, 0, 1))
    img = np.where(lamp, metal, img)
    inside_shade = ((x - c) / (0.09 * size)) ** 2 + (
        (y - c + 0.005 * size) / (0.03 * size)
    ) ** 2 <= 1
    img = np.where(inside_shade & (y > c - 0.01 * size), 0.12 * peak_cd_m2, img)  # lit rim
    return {"img": img, "desk": desk, "lamp": lamp}
