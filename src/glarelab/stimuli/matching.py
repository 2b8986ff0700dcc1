"""Stimuli of matching by adjustment (Yoshida et al. 2008): a disk on a background, with glare.

Reference images: the background with the disk at each level ``L_disk`` and glare added
(Yoshida eq. 1 and §3) by each of the protocol's glare methods, any registered glare model.
Everything is rendered at ``supersample`` times the display resolution and box-filtered down
(§3: "twice the resolution ... then filter and subsample"), so the disk's edge is antialiased.

Target images are glare-free: the background with the disk at the luminance the participant
sets. The session composes them as ``background + L × coverage`` (:func:`target_terms`), where
``coverage`` is the disk's area fraction per pixel and ``background`` the box-filtered
background with the disk cut out; at any ``L`` this equals rendering the disk at ``L`` without
glare, so a reference at or below L_dmax equals the target at its level.
"""

from __future__ import annotations

import numpy as np

from glarelab import glare
from glarelab.files.values import is_real, plain_array
from glarelab.glare.models.digitise import kernel_shape_for
from glarelab.protocols import Protocol, pixel_deg
from glarelab.protocols.common import glare_model
from glarelab.protocols.matching import reference_name
from glarelab.stimuli.backgrounds import BackgroundField, background
from glarelab.stimuli.kernels import KernelUse
from glarelab.stimuli.shapes import ImageRow

__all__ = [
    "box_filter",
    "build_matching",
    "compose_target",
    "matching_backgrounds",
    "matching_row",
    "target_terms",
]


def box_filter(image: np.ndarray, factor: int) -> np.ndarray:
    """Average ``factor × factor`` blocks (the filter-and-subsample of Yoshida §3).

    Parameters
    ----------
    image
        A supersampled image, ``(H, W)`` or ``(H, W, C)``; rows and columns beyond a whole
        number of blocks are dropped.
    factor
        The supersampling factor, an integer >= 1; 1 returns a copy.

    Returns
    -------
    numpy.ndarray
        ``(H // factor, W // factor[, C])``, each pixel the mean of its block.

    Examples
    --------
    >>> box_filter(np.arange(16.0).reshape(4, 4), 2).tolist()
    [[2.5, 4.5], [10.5, 12.5]]
    """
    if not (isinstance(factor, int | np.integer) and not isinstance(factor, bool)) or factor < 1:
        raise ValueError(f"factor must be a whole number >= 1; got {factor!r}")
    image = plain_array("image", image)
    if image.ndim not in (2, 3):
        raise ValueError(f"image must be (H, W) or (H, W, C); got shape {image.shape}")
    if factor == 1:
        return image.copy()
    h, w = image.shape[0] // factor, image.shape[1] // factor
    blocks = image[: h * factor, : w * factor].reshape(h, factor, w, factor, *image.shape[2:])
    return blocks.mean(axis=(1, 3))


def compose_target(background: np.ndarray, coverage: np.ndarray, disk_cd_m2: float) -> np.ndarray:
    """A glare-free target: the background with the disk at ``disk_cd_m2``.

    Parameters
    ----------
    background
        The target's background without the disk, cd/m² (``target_background``: zero
        under the disk).
    coverage
        The disk's area fraction in each pixel, 0-1 (``target_coverage``).
    disk_cd_m2
        The disk's luminance, cd/m².

    Returns
    -------
    numpy.ndarray
        ``background + disk_cd_m2 × coverage``, cd/m².

    Raises
    ------
    ValueError
        For a disk luminance that is not a finite number >= 0, a coverage outside 0-1 or
        not finite, a background with a negative or non-finite value, or the two of other
        shapes.

    Examples
    --------
    >>> compose_target(np.array([5.0, 0.0]), np.array([0.0, 1.0]), 120.0).tolist()
    [5.0, 120.0]
    """
    _check_disk(disk_cd_m2)
    background, coverage = np.asarray(background, float), np.asarray(coverage, float)
    if not (np.isfinite(coverage).all() and ((coverage >= 0) & (coverage <= 1)).all()):
        raise ValueError("coverage must hold area fractions, finite and within 0-1")
    if not (np.isfinite(background).all() and (background >= 0).all()):
        raise ValueError("background must hold finite luminances >= 0, cd/m²")
    if background.shape != coverage.shape:
        raise ValueError(
            f"background {background.shape} and coverage {coverage.shape} must have one shape"
        )
    return background + disk_cd_m2 * coverage


def target_terms(disk_cd_m2: float) -> list[tuple[str, float]]:
    """A target as a sum of set images (:func:`glarelab.stimuli.stimulus_set.compose`).

    Parameters
    ----------
    disk_cd_m2
        The disk's luminance the participant has set, cd/m².

    Returns
    -------
    list of tuple of (str, float)
        ``(image, weight)``: the background once, the disk's coverage times ``disk_cd_m2``.

    Raises
    ------
    ValueError
        For a disk luminance that is not a finite number >= 0.
    """
    _check_disk(disk_cd_m2)
    return [("target_background", 1.0), ("target_coverage", float(disk_cd_m2))]


def _check_disk(disk_cd_m2: object) -> None:
    if not (is_real(disk_cd_m2) and np.isfinite(float(disk_cd_m2)) and float(disk_cd_m2) >= 0):  # type: ignore[arg-type]
        raise ValueError(f"disk_cd_m2 must be a finite luminance >= 0, cd/m²; got {disk_cd_m2!r}")


def _odd(n: float) -> int:
    k = round(n)
    return k + 1 - k % 2


def matching_backgrounds(protocol: Protocol) -> list[BackgroundField]:
    """The background a matching protocol's builder draws: its field at the supersampled
    resolution, under the glare's ``l_dmax_cd_m2``.

    Parameters
    ----------
    protocol
        A validated protocol of the matching paradigm.

    Returns
    -------
    list of BackgroundField
        The one background, ``[background]``.
    """
    s = protocol["stimulus"]
    factor = s["supersample"]
    n = _odd(s["size_deg"] / pixel_deg(protocol)) * factor
    return [
        BackgroundField(
            "background",
            protocol["background"],
            (n, n),
            pixel_deg(protocol) / factor,
            protocol["glare"]["l_dmax_cd_m2"],
        )
    ]


def matching_kernels(protocol: Protocol) -> list[KernelUse]:
    """The kernels :func:`build_matching` digitises: each method's, at the supersampled pixel.

    Parameters
    ----------
    protocol
        A validated protocol of the matching paradigm.

    Returns
    -------
    list of KernelUse
        One per glare method, in the protocol's order.
    """
    s = protocol["stimulus"]
    fine_p = pixel_deg(protocol) / s["supersample"]
    fine_n = _odd(s["size_deg"] / pixel_deg(protocol)) * s["supersample"]
    return [
        KernelUse(
            f"glare.methods[{index}].parameters",
            glare_model(method["model"], method["parameters"]),
            fine_p,
            kernel_shape_for((fine_n, fine_n)),
        )
        for index, method in enumerate(protocol["glare"]["methods"])
    ]


def build_matching(protocol: Protocol, *, progress=None) -> dict:
    """Render the reference and target images of a matching protocol.

    Parameters
    ----------
    protocol
        A validated protocol of the matching paradigm.
    progress
        Optional callable ``progress(done, total, what)``.

    Returns
    -------
    dict
        ``images``: name → dict with ``img`` (cd/m², display resolution), ``kind``
        (``'reference'``, ``'target'`` or ``'component'``) and parameters; ``geometry``: pixel
        size, sizes in pixels, disk centre and diameter, gap; ``parameters``: what was rendered
        and how.
    """
    s, g = protocol["stimulus"], protocol["glare"]
    p = pixel_deg(protocol)
    factor = s["supersample"]
    n = _odd(s["size_deg"] / p)
    fine_p = p / factor
    fine_n = n * factor
    rng = np.random.default_rng(protocol.seed)
    (drawn,) = matching_backgrounds(protocol)
    field = background(
        drawn.spec,
        drawn.shape,
        pixel_deg=drawn.pixel_deg,
        rng=rng,
        ceiling_cd_m2=drawn.ceiling_cd_m2,
        folder=protocol.folder,
    )
    # fine pixel centres in degrees; the disk centre is the centre of native pixel n // 2
    axis = (np.arange(fine_n) - (fine_n - 1) / 2) * fine_p
    mask = np.hypot(axis[None, :], axis[:, None]) <= s["disk_deg"] / 2
    images: dict[str, dict] = {}
    coverage = box_filter(mask.astype(float), factor)
    cut = box_filter(field * ~mask, factor)
    images["target_background"] = {"img": cut, "kind": "component"}
    images["target_coverage"] = {"img": coverage, "kind": "component"}
    images["background"] = {"img": box_filter(field, factor), "kind": "component"}
    for i, start in enumerate(s["target_start_cd_m2"]):
        name = ("target_start_darker", "target_start_brighter")[i]
        images[name] = {
            "img": compose_target(cut, coverage, start),
            "kind": "target",
            "disk_cd_m2": start,
        }
    total = sum(len(m["levels_cd_m2"]) for m in g["methods"])
    done = 0
    shape = kernel_shape_for((fine_n, fine_n))
    models = {}
    for method, use in zip(g["methods"], matching_kernels(protocol), strict=True):
        model = use.model
        models[method["name"]] = repr(model)
        kernel = glare.digitise_kernel(model, fine_p, shape)  # from the kernel cache
        renderer = glare.GlareRenderer(  # exact; the kernel's spectrum is kept across levels
            model,
            pixel_deg=fine_p,
            shape=(fine_n, fine_n),
            l_dmax_cd_m2=g["l_dmax_cd_m2"],
            tolerance_codes=0,
            kernel=kernel,
        )
        for label, level in zip(method["labels"], method["levels_cd_m2"], strict=True):
            scene = np.where(mask, level, field)
            result = renderer.render(scene)
            images[reference_name(method["name"], label)] = {
                "img": box_filter(result.image, factor),
                "kind": "reference",
                "method": method["name"],
                "label": label,
                "disk_cd_m2": level,
                "energy_outside_kernel": float(np.max(kernel.energy_outside)),
            }
            done += 1
            if progress is not None:
                progress(done, total, f"reference {method['name']} {label}")
    return {
        "images": images,
        "geometry": {
            "pixel_deg": p,
            "size_px": n,
            "supersample": factor,
            "disk_diameter_deg": s["disk_deg"],
            "disk_diameter_px": s["disk_deg"] / p,
            "centre_px": [n // 2, n // 2],
            "gap_px": round(s["gap_deg"] / p),
        },
        "parameters": {
            "models": models,
            "kernel_shape_fine": list(shape),
            "background": dict(protocol["background"]),
        },
    }


def matching_row(protocol: Protocol, display_pixel_deg: float) -> ImageRow:
    """The first trial's images on the protocol's display: the reference and the targets
    (two, or three when the darker and brighter bounds are set), each rendered at the
    display's pixel and odd so that the disk has a centre pixel.

    Parameters
    ----------
    protocol
        A validated protocol of the paradigm.
    display_pixel_deg
        Visual angle of one pixel of the display the session runs on, degrees.

    Returns
    -------
    ImageRow
        The images' sizes and gap in display pixels, with notes where whole pixels depart
        from the protocol's ``size_deg`` and ``gap_deg``.
    """
    s = protocol["stimulus"]
    size = _odd(s["size_deg"] / display_pixel_deg)
    gap = round(s["gap_deg"] / display_pixel_deg)
    count = 3 if protocol["trials"]["settings"] == "bounds" else 2
    notes = [
        f"stimulus.size_deg = {s['size_deg']:g} is {s['size_deg'] / display_pixel_deg:.2f} "
        f"display pixels: rendered and drawn as {size} px ({size * display_pixel_deg:.4g}°, odd "
        "so the disk has a centre pixel)",
        f"stimulus.gap_deg = {s['gap_deg']:g} is drawn as {gap} px "
        f"({gap * display_pixel_deg:.4g}°)",
    ]
    return ImageRow([(size, size)] * count, gap, None, notes)
