"""The error of ``aperture_grid='fast'`` in display codes: a lamp on a dark street.

``WaveOpticsGlare(aperture_grid="fast")`` keeps the aperture grid and the one-sample drawing
from before the prefilters of polygons, the lid, cross screens and obstacle images. For each
aperture of ``scripts/measure_combined_prefilter.py`` (its cases), a 3 × 3 pixel lamp of
1e5 cd/m² on 0.1 cd/m² (201², 0.02°/px, the default 31 wavelengths) is rendered with both
kernels; the worst difference is read in the codes of the reference display (10-bit,
gamma 2.2, 1000:1, white 200 cd/m²), with both kernels' times.

Run: ``python scripts/measure_fast_drawing.py --out docs/optics/fast_drawing_codes.csv``.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from measure_combined_prefilter import IMAGE_CASES, NONE, OTHER_CASES, bitmap

from glarelab.glare import render_glare
from glarelab.glare.models.wave import WaveOpticsGlare
from glarelab.glare.rendering.display import display_codes, display_lut

PIXEL_DEG = 0.02
SIZE = 201
L_DMAX = 200.0


def cases() -> dict[str, WaveOpticsGlare]:
    models = {name: WaveOpticsGlare(**p) for name, p in OTHER_CASES.items()}
    models["hexagon 4 mm at 0°"] = WaveOpticsGlare(pupil_mm=4.0, diaphragm_sides=6, **NONE)
    for name, (pupil, kind, spacing) in IMAGE_CASES.items():
        models[name] = WaveOpticsGlare(
            pupil_mm=pupil, obstacle_image=bitmap(spacing, kind), obstacle_spacing_mm=spacing,
            **NONE,
        )  # fmt: skip
    return models


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    out = parser.parse_args().out
    scene = np.full((SIZE, SIZE), 0.1)
    scene[SIZE // 2 - 1 : SIZE // 2 + 2, SIZE // 2 - 1 : SIZE // 2 + 2] = 1e5
    lut = display_lut(None, L_DMAX)
    rows = []
    for name, model in cases().items():
        codes, seconds = {}, {}
        try:  # an 8 mm pupil's exact grid for the default 4° PSF exceeds 8192²: 2° then
            model.grid_for(PIXEL_DEG, (SIZE, SIZE))
        except ValueError:
            model = replace(model, psf_extent_deg=2.0)
        for grid in ("exact", "fast"):
            glare = replace(model, aperture_grid=grid)
            start = time.perf_counter()
            kernel = glare.kernel(PIXEL_DEG, (SIZE, SIZE))
            seconds[grid] = time.perf_counter() - start
            shown = render_glare(
                scene, glare, pixel_deg=PIXEL_DEG, l_dmax_cd_m2=L_DMAX, kernel=kernel
            ).image
            codes[grid] = display_codes(shown, lut)
        error = np.abs(codes["fast"] - codes["exact"])
        worst = np.unravel_index(np.argmax(error), error.shape)
        radius_deg = PIXEL_DEG * float(np.hypot(worst[0] - SIZE // 2, worst[1] - SIZE // 2))
        rows.append({
            "aperture": name,
            "max_codes": f"{error.max():.3f}",
            "at_deg": f"{radius_deg:.2f}",
            "psf_extent_deg": f"{model.psf_extent_deg:g}",
            "exact_kernel_s": f"{seconds['exact']:.2f}",
            "fast_kernel_s": f"{seconds['fast']:.2f}",
        })  # fmt: skip
        print(" | ".join(rows[-1].values()), flush=True)
    tmp = out.with_name(out.name + ".partial")
    with tmp.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    tmp.replace(out)


if __name__ == "__main__":
    main()
