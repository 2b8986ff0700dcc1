"""``glarelab bench --acuity``: what the fast ways of the acuity blur cost in accuracy.

Luidolt's acuity loss (§5.3, eqs. 5.14-5.15) blurs each pixel by a Gaussian of its own σ. The
reference is that sum pixel by pixel (``blur='exact'``: ``(2r + 1)²`` passes over the image for
the largest reach ``r``); against it, in the same run, the contenders are timed (interleaved,
best of ``repeats``) and their error measured in display codes (continuous codes of the night
study's display, 10-bit, 200 cd/m², gamma 2.2: 0.5 is half a step):

- ``layers`` with 1, 2, 4 (default) and 8 levels per octave: scipy's separable Gaussian filter
  at a ladder of σ, each pixel interpolated between the two levels around its σ;
- ``separable``: Luidolt's two 1-D passes (§5.3.3);
- a uniform blur at the median σ (``scipy.ndimage.gaussian_filter``): what ignoring the
  variation costs, the cheapest a user could write.

Workloads: the night street of ``src/glarelab/protocols/night2026.toml`` as the pipeline
blurs it (after exposure for its adapted luminance), at the study's pixel (0.0297°) and at a
finer one (0.01°, a headset or a 4K display at 1 m), where σ spans more pixels.
"""

from __future__ import annotations

import csv
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy import ndimage

from glarelab import glare
from glarelab.bench.timing import timed
from glarelab.display.calibration import synthetic_calibration
from glarelab.files.atomic import atomic_open, write_text
from glarelab.glare.night.acuity import blur_sigma_deg, layers_error_bound
from glarelab.glare.rendering.display import display_codes
from glarelab.stimuli.night import night_street

__all__ = ["ACUITY_WORKLOADS", "acuity_bench", "acuity_table", "write_acuity_bench"]

# (size, pixel in degrees): the study's display (27 in, 1920 × 1080 at 0.6 m) and a finer one
ACUITY_WORKLOADS = {
    "street_0.0297deg": ((640, 400), 0.0297),
    "street_0.01deg": ((640, 400), 0.01),
}
DISPLAY_MAX_CD_M2 = 200.0  # night2026.toml's display
ADAPTED_DISPLAY_CD_M2 = 3.0  # and its key


def _scene(size: tuple[int, int], pixel_deg: float) -> tuple[np.ndarray, float]:
    """The street on the display as the pipeline blurs it, and its exposure."""
    street = night_street(
        size, pixel_deg=pixel_deg, lamps=3, lamp_cd_m2=1e4, ambient_cd_m2=0.05,
        rng=np.random.default_rng(0),
    )["img"]  # fmt: skip
    adapted = glare.frame_luminance(street, pixel_deg=pixel_deg)
    exposure = ADAPTED_DISPLAY_CD_M2 / adapted
    return np.minimum(street * exposure, DISPLAY_MAX_CD_M2), exposure


def acuity_bench(
    *, repeats: int = 3, only: tuple[str, ...] | None = None, log: Callable[[str], None] = print
) -> list[dict]:
    """Time every way of the acuity blur against the exact one on each workload (``only``:
    these of :data:`ACUITY_WORKLOADS`).

    Parameters
    ----------
    repeats
        Timed runs of each variant, the fastest kept; default 3.
    only
        Workload names to run; default None: all.
    log
        Called with a line per workload; default :func:`print`.

    Returns
    -------
    list of dict
        One row per workload and variant: ``seconds``, ``speedup`` (exact's time over this
        one's), ``max_codes`` and ``p999_codes`` (the error, display codes), ``bound`` (the
        layers' stated bound as a fraction of the range, or None) and the σ range in pixels.
    """
    lut = synthetic_calibration(max_cd_m2=DISPLAY_MAX_CD_M2, black_cd_m2=0.05, bit_depth=10).lut
    rows = []
    for name, (size, pixel) in ACUITY_WORKLOADS.items():
        if only is not None and name not in only:
            continue
        image, exposure = _scene(size, pixel)
        log(f"acuity {name}: {size[0]} × {size[1]} px at {pixel:g}°")
        sigma_px = blur_sigma_deg(glare.adaptation.luminance(image) / exposure) / pixel
        median = float(np.median(sigma_px))

        def blur(how: str, levels: int = 4, image=image, exposure=exposure, pixel=pixel):
            return lambda: glare.acuity_blur(
                image, pixel_deg=pixel, blur=how, white_cd_m2=DISPLAY_MAX_CD_M2,
                luminance_scale=1.0 / exposure,
                levels_per_octave=levels if how == "layers" else None,
            )  # fmt: skip

        variants = {"exact": blur("exact")}
        variants |= {f"layers, {n}/octave": blur("layers", n) for n in (1, 2, 4, 8, 16)}
        variants["separable (Luidolt §5.3.3)"] = blur("separable")
        variants["uniform σ (gaussian_filter)"] = lambda image=image, s=median: (
            ndimage.gaussian_filter(image, sigma=(s, s, 0), mode="nearest")
        )
        measured = timed(variants, repeats)
        reference_time, reference = measured["exact"]
        codes = display_codes(reference, lut)
        for variant, (seconds, result) in measured.items():
            error = np.abs(display_codes(result, lut) - codes)
            levels = variant.split(", ")[1].split("/")[0] if variant.startswith("layers") else None
            rows.append(
                {
                    "workload": name,
                    "variant": variant,
                    "seconds": seconds,
                    "speedup": reference_time / seconds,
                    "max_codes": float(error.max()),
                    "p999_codes": float(np.quantile(error, 0.999)),
                    "bound": layers_error_bound(int(levels)) if levels else None,
                    "sigma_px_min": float(sigma_px.min()),
                    "sigma_px_max": float(sigma_px.max()),
                }
            )
            log(
                f"    {variant:<30} {seconds:8.3f} s  ×{reference_time / seconds:6.1f}  "
                f"max {error.max():.3f} codes"
            )
    return rows


def acuity_table(rows: list[dict]) -> str:
    """The rows as a Markdown table.

    Parameters
    ----------
    rows
        The rows of :func:`acuity_bench`.

    Returns
    -------
    str
        The table, one line per row, ending in a new line.
    """
    lines = [
        "| workload | σ (px) | variant | time (s) | speed-up over exact | max error (codes) "
        "| 99.9 % (codes) | stated bound (of the range) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        bound = "" if r["bound"] is None else f"{r['bound']:.4f}"
        lines.append(
            f"| {r['workload']} | {r['sigma_px_min']:.2f}-{r['sigma_px_max']:.2f} | "
            f"{r['variant']} | {r['seconds']:.3f} | {r['speedup']:.1f} | "
            f"{r['max_codes']:.3f} | {r['p999_codes']:.3f} | {bound} |"
        )
    return "\n".join(lines) + "\n"


def write_acuity_bench(out: Path, rows: list[dict]) -> None:
    """``acuity.csv`` and ``acuity.md`` in ``out``.

    Parameters
    ----------
    out
        The folder, existing; the two files are written whole or not at all.
    rows
        The rows of :func:`acuity_bench`, at least one.
    """
    with atomic_open(out / "acuity.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    write_text(out / "acuity.md", acuity_table(rows))
