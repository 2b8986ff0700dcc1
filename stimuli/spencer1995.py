"""The stimuli of Spencer et al. (1995, §4): a light source with and without glare.

Each trial shows two 300 × 300 windows on black: the **glare image**, a small source whose
glare (the Vos PSF with ciliary-corona flare lines) is rendered at one of 12 strengths, with its
peak at 75 % of the display maximum; and the **comparison image**, the same scene with the
source replaced by a disc and an annulus of one third the disc's intensity, which the staircase
varies from 0 to 100 % of the display maximum.

Glare strength is the source's excess over the displayed peak: a source of
``peak × (1 + strength)`` is rendered and clamped at the peak (Yoshida eq. 1 with
``L_dmax = peak``), so strength 0.01 is "a slightly blurry dot" and 284 "a light source which
had too much glare to be believable" (§4).

The **context** scene is a lamp on a desk in a dark room, drawn procedurally (the paper's
photograph is not available): a desk top with wood grain and a pool of lamp light, a lamp base,
arm and shade, and the bulb at the window centre, where the source is.
"""

from __future__ import annotations

import math

import numpy as np

import glare
from glare.digitise import kernel_shape_for

from .protocol import Protocol
from .protocol import pixel_deg as display_pixel_deg

__all__ = ["build_spencer1995", "compose_comparison", "lamp_scene"]

ROOM_CD_M2 = 0.05  # a darkened room (§4)


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
    """
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


def compose_comparison(
    scene: np.ndarray, disc: np.ndarray, annulus: np.ndarray, intensity_cd_m2: float, ratio: float
) -> np.ndarray:
    """The comparison image: the scene with a disc at ``intensity`` and an annulus at
    ``ratio × intensity`` where the source was (``disc``, ``annulus``: area fractions)."""
    cover = np.clip(disc + annulus, 0.0, 1.0)
    return scene * (1.0 - cover) + intensity_cd_m2 * (disc + ratio * annulus)


def _circle_coverage(size: int, radius: float, factor: int = 8) -> np.ndarray:
    """Area fraction of a centred circle in each pixel (``factor``² samples per pixel)."""
    offsets = (np.arange(size * factor) + 0.5) / factor - size / 2
    inside = np.hypot(offsets[None, :], offsets[:, None]) <= radius
    return inside.reshape(size, factor, size, factor).mean(axis=(1, 3))


def build_spencer1995(protocol: Protocol, *, progress=None) -> dict:
    """Render the glare and comparison images of a Spencer 1995 protocol.

    Returns
    -------
    dict
        ``images``: name → dict with ``img`` (cd/m²) and parameters; ``geometry``;
        ``parameters``.
    """
    s, g = protocol["stimulus"], protocol["glare"]
    size = s["window_px"]
    p = s["pixel_deg"] if s["pixel_deg"] > 0 else display_pixel_deg(protocol)
    maximum = protocol["display"]["max_cd_m2"]
    peak = g["peak_fraction"] * maximum
    rng = np.random.default_rng(protocol.seed)
    scenes = {"none": np.zeros((size, size))}
    if "lamp" in s["context"]:
        scenes["lamp"] = lamp_scene(size, rng=rng, peak_cd_m2=peak)["img"]
    source = _circle_coverage(size, s["source_radius_px"])
    disc = _circle_coverage(size, s["disc_radius_px"])
    annulus = _circle_coverage(size, s["annulus_outer_px"]) - disc
    model = glare.VosGlare(regime=g["regime"], flare_lines=g["flare_lines"], seed=protocol.seed)
    kernel = model.kernel(p, kernel_shape_for((size, size)))
    renderer = glare.GlareRenderer(  # exact; the kernel's spectrum is kept across images
        model, pixel_deg=p, shape=(size, size), l_dmax_cd_m2=peak, tolerance_codes=0, kernel=kernel
    )
    images: dict[str, dict] = {
        "comparison_disc": {"img": disc, "kind": "component"},
        "comparison_annulus": {"img": annulus, "kind": "component"},
    }
    total = len(s["context"]) * (len(g["strengths"]) + 1)
    done = 0
    for context in s["context"]:
        scene = scenes[context]
        images[f"scene_{context}"] = {"img": scene, "kind": "component", "context": context}
        images[f"comparison_{context}_full"] = {
            "img": compose_comparison(scene, disc, annulus, maximum, s["annulus_ratio"]),
            "kind": "comparison",
            "context": context,
            "intensity_fraction": 1.0,
        }
        done += 1
        if progress is not None:
            progress(done, total, f"comparison {context}")
        for level, strength in enumerate(g["strengths"], start=1):
            source_l = peak * (1.0 + strength)
            hdr = scene * (1.0 - source) + source_l * source
            result = renderer.render(hdr)
            images[f"glare_{context}_{level:02d}"] = {
                "img": result.image,
                "kind": "glare",
                "context": context,
                "level": level,
                "strength": strength,
                "source_cd_m2": source_l,
            }
            done += 1
            if progress is not None:
                progress(done, total, f"glare {context} {level:02d}")
    return {
        "images": images,
        "geometry": {"pixel_deg": p, "window_px": size, "centre_px": [size // 2, size // 2]},
        "parameters": {
            "model": repr(model),
            "peak_cd_m2": peak,
            "kernel_energy_outside": float(kernel.energy_outside),
            "source_area_px": float(source.sum()),
            "radians_per_px": math.radians(p),
        },
    }
