"""Stimuli of the three-way staircase (Spencer et al. 1995, §4): a light source with and without
glare.

Each trial shows two square windows: the **glare image**, a small source whose glare (any
registered glare model; Spencer: the Vos PSF with ciliary-corona flare lines) is rendered at
one of several strengths, with its peak at ``peak_fraction`` of the display maximum; and the
**comparison image**, the same scene with the source replaced by a disc and an annulus of
``annulus_ratio`` of the disc's intensity, which the staircase varies from 0 to 100 % of the
display maximum. Each context puts the source on its own background (Spencer: a black field,
and a lamp on a desk).

Glare strength is the source's excess over the displayed peak: a source of
``peak × (1 + strength)`` is rendered and clamped at the peak (Yoshida eq. 1 with
``L_dmax = peak``), so strength 0.01 is "a slightly blurry dot" and 284 "a light source which
had too much glare to be believable" (§4).
"""

from __future__ import annotations

import math

import numpy as np

from glarelab import glare
from glarelab.glare.models.digitise import kernel_shape_for
from glarelab.protocols import Protocol
from glarelab.protocols import pixel_deg as display_pixel_deg
from glarelab.protocols.common import glare_model
from glarelab.protocols.staircase import glare_name
from glarelab.stimuli.backgrounds import BackgroundField, background
from glarelab.stimuli.kernels import KernelUse
from glarelab.stimuli.shapes import ImageRow

__all__ = ["build_staircase", "compose_comparison", "staircase_backgrounds", "staircase_row"]


def compose_comparison(
    scene: np.ndarray, disc: np.ndarray, annulus: np.ndarray, intensity_cd_m2: float, ratio: float
) -> np.ndarray:
    """The comparison image: the scene with a disc at ``intensity`` and an annulus at
    ``ratio × intensity`` where the source was (``disc``, ``annulus``: area fractions).

    Parameters
    ----------
    scene
        The context's scene without the source, cd/m².
    disc, annulus
        The area fraction of the disc and of the annulus in each pixel, 0-1.
    intensity_cd_m2
        The disc's luminance, cd/m².
    ratio
        The annulus's luminance as a multiple of the disc's.

    Returns
    -------
    numpy.ndarray
        The comparison image, cd/m².
    """
    cover = np.clip(disc + annulus, 0.0, 1.0)
    return scene * (1.0 - cover) + intensity_cd_m2 * (disc + ratio * annulus)


def _circle_coverage(size: int, radius: float, factor: int = 8) -> np.ndarray:
    """Area fraction of a centred circle in each pixel (``factor``² samples per pixel)."""
    offsets = (np.arange(size * factor) + 0.5) / factor - size / 2
    inside = np.hypot(offsets[None, :], offsets[:, None]) <= radius
    return inside.reshape(size, factor, size, factor).mean(axis=(1, 3))


def staircase_backgrounds(protocol: Protocol) -> list[BackgroundField]:
    """The backgrounds a staircase protocol's builder draws: each context's, filling the
    window, under the source's peak (``peak_fraction`` of the display's maximum).

    Parameters
    ----------
    protocol
        A validated protocol of the staircase paradigm.

    Returns
    -------
    list of BackgroundField
        One per context, in the protocol's order (the order they are drawn in).
    """
    s = protocol["stimulus"]
    size = s["window_px"]
    p = s["pixel_deg"] if s["pixel_deg"] > 0 else display_pixel_deg(protocol)
    peak = protocol["glare"]["peak_fraction"] * protocol["display"]["max_cd_m2"]
    return [
        BackgroundField(f"contexts[{i}].background", c["background"], (size, size), p, peak)
        for i, c in enumerate(protocol["contexts"])
    ]


def staircase_kernels(protocol: Protocol) -> list[KernelUse]:
    """The kernel :func:`build_staircase` digitises: the study's one model, over the window.

    Parameters
    ----------
    protocol
        A validated protocol of the staircase paradigm.

    Returns
    -------
    list of KernelUse
        The one kernel, ``[kernel]``.
    """
    s, g = protocol["stimulus"], protocol["glare"]
    size = s["window_px"]
    p = s["pixel_deg"] if s["pixel_deg"] > 0 else display_pixel_deg(protocol)
    model = glare_model(g["model"], g["parameters"])
    return [KernelUse("glare.parameters", model, p, kernel_shape_for((size, size)))]


def build_staircase(protocol: Protocol, *, progress=None) -> dict:
    """Render the glare and comparison images of a staircase protocol.

    Parameters
    ----------
    protocol
        A validated protocol of the staircase paradigm.
    progress
        Optional callable ``progress(done, total, what)``, called after each image or
        condition (:func:`glarelab.stimuli.stimulus_set.progress_bar`); default ``None``: none.

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
    source = _circle_coverage(size, s["source_radius_px"])
    disc = _circle_coverage(size, s["disc_radius_px"])
    annulus = _circle_coverage(size, s["annulus_outer_px"]) - disc
    cover = np.clip(disc + annulus, 0.0, 1.0)
    (use,) = staircase_kernels(protocol)
    model = use.model
    kernel = glare.digitise_kernel(model, p, use.shape)  # kernel cache
    renderer = glare.GlareRenderer(  # exact; the kernel's spectrum is kept across images
        model, pixel_deg=p, shape=(size, size), l_dmax_cd_m2=peak, tolerance_codes=0, kernel=kernel
    )
    images: dict[str, dict] = {
        "comparison_disc": {"img": disc, "kind": "component"},
        "comparison_annulus": {"img": annulus, "kind": "component"},
    }
    total = len(protocol["contexts"]) * (len(g["strengths"]) + 1)
    done = 0
    for context, drawn in zip(protocol["contexts"], staircase_backgrounds(protocol), strict=True):
        name = context["name"]
        scene = background(
            drawn.spec,
            drawn.shape,
            pixel_deg=drawn.pixel_deg,
            rng=rng,
            ceiling_cd_m2=drawn.ceiling_cd_m2,
            folder=protocol.folder,
        )
        images[f"scene_{name}"] = {"img": scene, "kind": "component", "context": name}
        images[f"scene_{name}_outside"] = {
            "img": scene * (1.0 - cover),
            "kind": "component",
            "context": name,
        }
        images[f"comparison_{name}_full"] = {
            "img": compose_comparison(scene, disc, annulus, maximum, s["annulus_ratio"]),
            "kind": "comparison",
            "context": name,
            "intensity_fraction": 1.0,
        }
        done += 1
        if progress is not None:
            progress(done, total, f"comparison {name}")
        for level, strength in enumerate(g["strengths"], start=1):
            source_l = peak * (1.0 + strength)
            hdr = scene * (1.0 - source) + source_l * source
            result = renderer.render(hdr)
            images[glare_name(name, level)] = {
                "img": result.image,
                "kind": "glare",
                "context": name,
                "level": level,
                "strength": strength,
                "source_cd_m2": source_l,
            }
            done += 1
            if progress is not None:
                progress(done, total, f"glare {name} {level:02d}")
    return {
        "images": images,
        "geometry": {
            "pixel_deg": p,
            "window_px": size,
            "centre_px": [(size - 1) / 2, (size - 1) / 2],  # pixel (i, j) is centred at (i, j)
            "gap_px": s["window_gap_px"],
            "source_diameter_deg": 2 * s["source_radius_px"] * p,
            "disc_diameter_deg": 2 * s["disc_radius_px"] * p,
        },
        "parameters": {
            "model": repr(model),
            "peak_cd_m2": peak,
            "kernel_energy_outside": float(np.max(kernel.energy_outside)),
            "source_area_px": float(source.sum()),
            "radians_per_px": math.radians(p),
        },
    }


def staircase_row(protocol: Protocol, display_pixel_deg: float) -> ImageRow:
    """The two windows of a flash, side by side, at the protocol's own pixel angle (0: the
    display's).

    Parameters
    ----------
    protocol
        A validated protocol of the paradigm.
    display_pixel_deg
        Visual angle of one pixel of the display the session runs on, degrees. Not used:
        the row carries the protocol's own ``pixel_deg`` (0: the display's).

    Returns
    -------
    ImageRow
        Two ``window_px`` squares, ``window_gap_px`` apart.
    """
    s = protocol["stimulus"]
    return ImageRow([(s["window_px"], s["window_px"])] * 2, s["window_gap_px"], s["pixel_deg"])
