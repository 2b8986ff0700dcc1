"""The stimuli of Yoshida et al. (2008): a 0.3° disk on a cloudy sky, with glare.

Reference images: the sky with the disk at each level ``L_disk`` and glare added (Yoshida
eq. 1 and §3), for Method I (Gaussian, σ = 0.34°) and Method II (Vos PSF). Everything is
rendered at ``supersample`` times the display resolution and box-filtered down (§3: "twice the
resolution ... then filter and subsample"), so the disk's edge is antialiased.

Target images are glare-free: the sky with the disk at the luminance the participant sets. The
experiment composes them as ``background + L × coverage``, where ``coverage`` is the disk's
area fraction per pixel and ``background`` the box-filtered sky with the disk cut out; at any
``L`` this equals rendering the disk at ``L`` without glare, so reference level A (220 cd/m²,
nothing above L_dmax) equals the target at 220 cd/m².
"""

from __future__ import annotations

import numpy as np

import glare
from glare.digitise import kernel_shape_for

from .protocol import Protocol, pixel_deg
from .sky import cloudy_sky

__all__ = ["box_filter", "build_yoshida2008", "compose_target"]


def box_filter(image: np.ndarray, factor: int) -> np.ndarray:
    """Average ``factor × factor`` blocks (the filter-and-subsample of Yoshida §3)."""
    if factor == 1:
        return image.copy()
    h, w = image.shape[0] // factor, image.shape[1] // factor
    return image[: h * factor, : w * factor].reshape(h, factor, w, factor).mean(axis=(1, 3))


def compose_target(background: np.ndarray, coverage: np.ndarray, disk_cd_m2: float) -> np.ndarray:
    """A glare-free target: the sky with the disk at ``disk_cd_m2``."""
    return background + disk_cd_m2 * coverage


def _odd(n: float) -> int:
    k = round(n)
    return k + 1 - k % 2


def build_yoshida2008(protocol: Protocol, *, progress=None) -> dict:
    """Render the reference and target images of a Yoshida 2008 protocol.

    Parameters
    ----------
    protocol
        A validated ``yoshida2008`` protocol.
    progress
        Optional callable ``progress(done, total, what)``.

    Returns
    -------
    dict
        ``images``: name → dict with ``img`` (cd/m², display resolution), ``kind``
        (``'reference'``, ``'target'`` or ``'component'``) and parameters; ``geometry``: pixel
        size, sizes in pixels, disk centre; ``parameters``: what was rendered and how.
    """
    s, g = protocol["stimulus"], protocol["glare"]
    p = pixel_deg(protocol)
    factor = s["supersample"]
    n = _odd(s["background_deg"] / p)
    fine_p = p / factor
    fine_n = n * factor
    rng = np.random.default_rng(protocol.seed)
    sky = cloudy_sky(
        (fine_n, fine_n),
        pixel_deg=fine_p,
        rng=rng,
        mean_cd_m2=s["background_mean_cd_m2"],
        contrast=s["cloud_contrast"],
        cloud_min_deg=s["cloud_min_deg"],
        cloud_max_deg=s["cloud_max_deg"],
        slope=s["cloud_spectrum_slope"],
        ceiling_cd_m2=0.98 * g["l_dmax_cd_m2"],
    )
    # fine pixel centres in degrees; the disk centre is the centre of native pixel n // 2
    axis = (np.arange(fine_n) - (fine_n - 1) / 2) * fine_p
    mask = np.hypot(axis[None, :], axis[:, None]) <= s["disk_deg"] / 2
    images: dict[str, dict] = {}
    coverage = box_filter(mask.astype(float), factor)
    background = box_filter(sky * ~mask, factor)
    images["target_background"] = {"img": background, "kind": "component"}
    images["target_coverage"] = {"img": coverage, "kind": "component"}
    images["sky"] = {"img": box_filter(sky, factor), "kind": "component"}
    for i, start in enumerate(s["target_start_cd_m2"]):
        side = ("darker", "brighter")[i]
        images[f"target_start_{side}"] = {
            "img": compose_target(background, coverage, start),
            "kind": "target",
            "disk_cd_m2": start,
        }

    methods = {
        "gaussian": glare.GaussianGlare(sigma_deg=g["gaussian"]["sigma_deg"]),
        "vos": glare.VosGlare(regime=g["vos"]["regime"]),
    }
    total = sum(len(g[m]["levels_cd_m2"]) for m in methods)
    done = 0
    for method, model in methods.items():
        kernel = model.kernel(fine_p, kernel_shape_for((fine_n, fine_n)))
        renderer = glare.GlareRenderer(  # exact; the kernel's spectrum is kept across levels
            model,
            pixel_deg=fine_p,
            shape=(fine_n, fine_n),
            l_dmax_cd_m2=g["l_dmax_cd_m2"],
            tolerance_codes=0,
            kernel=kernel,
        )
        for label, level in zip(g[method]["labels"], g[method]["levels_cd_m2"], strict=True):
            scene = np.where(mask, level, sky)
            result = renderer.render(scene)
            images[f"reference_{method}_{label}"] = {
                "img": box_filter(result.image, factor),
                "kind": "reference",
                "method": method,
                "label": label,
                "disk_cd_m2": level,
                "energy_outside_kernel": float(kernel.energy_outside),
            }
            done += 1
            if progress is not None:
                progress(done, total, f"reference {method} {label}")
    return {
        "images": images,
        "geometry": {
            "pixel_deg": p,
            "size_px": n,
            "supersample": factor,
            "disk_diameter_px": s["disk_deg"] / p,
            "centre_px": [n // 2, n // 2],
        },
        "parameters": {
            "models": {m: repr(model) for m, model in methods.items()},
            "kernel_shape_fine": list(kernel_shape_for((fine_n, fine_n))),
            "sky": {
                "seed": protocol.seed,
                "mean_cd_m2": s["background_mean_cd_m2"],
                "contrast": s["cloud_contrast"],
                "cloud_min_deg": s["cloud_min_deg"],
                "cloud_max_deg": s["cloud_max_deg"],
                "slope": s["cloud_spectrum_slope"],
                "ceiling_cd_m2": 0.98 * g["l_dmax_cd_m2"],
            },
        },
    }
