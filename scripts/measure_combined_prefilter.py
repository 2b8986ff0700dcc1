"""Measure a diaphragm behind other obstacles, with every edge drawn by the one-sample cover
(the model before) and with the whole aperture under the diaphragm's prefilter (the model),
against a finely drawn reference, ring by ring.

Writes the numbers of docs/optics-departures.md ("wave kernels out to their border", a
diaphragm with other obstacles) as CSV:

    PYTHONPATH=src:. python scripts/measure_combined_prefilter.py --out docs/optics

``combined_prefilter.csv``: for a diaphragm at a rotation that puts a streak on an axis, behind
the lid, a 4-point cross screen, particles, or lid, lashes and particles, at 380 and 780 nm,
the 0.2-0.3° ring and the border of a 31² kernel at 0.02°/px, model / reference - 1:

- ``one_sample``: every obstacle drawn by its one-sample cover, whose transfer ``sinc`` is
  divided out (the model before; now only with lashes, particles, a trigonal cross screen or
  an obstacle image, which it keeps);
- ``model``: the model (``WaveOpticsGlare.monochromatic_kernels``): with the lid or a 4-point
  cross screen, the whole aperture under ``DIAPHRAGM_PREFILTER``
  (``apertures.aperture_diaphragm_prefiltered``);
- ``one_sample_s``, ``model_s``: the time of each, two wavelengths, the shortest of three
  runs on the machine it runs on.

The reference is the same aperture drawn by its one-sample cover on a grid of 16/8192 mm
(0.002 mm; its streaks' copies 0.24 % of them at 380 nm, not 9.7 %), its pixels integrated
exactly from its autocorrelation. ``reference_check`` is a second, independent reference / the
first - 1: that drawing zero-padded to 8192², one FFT, the cells' transfer divided out, the
samples rebinned onto the pixels. For a triangle alone the first agrees with the polygon's
exact transform (a sum over its edges) to 0.09 % (``--check``).
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np
import scipy.fft

from glarelab.glare import WaveOpticsGlare
from glarelab.glare.models import apertures as ap
from glarelab.glare.models.fraunhofer import (
    aperture_autocorrelation,
    pixel_integrated_psf,
    rebin,
)
from glarelab.glare.models.spectral import Spectrum

PIXEL_DEG, SHAPE = 0.02, (31, 31)
TWO_WAVELENGTHS = Spectrum(n_wavelengths=2, wavelength_range_nm=(380.0, 780.0))
NONE = {"eyelashes": False, "eyelid": False, "particles": 0}
LID = {**NONE, "eyelid": True}
CASES = {
    "triangle 3 mm at 0°, lid": dict(pupil_mm=3.0, diaphragm_sides=3, **LID),
    "square 2 mm at 45°, lid": dict(
        pupil_mm=2.0, diaphragm_sides=4, diaphragm_rotation_deg=45.0, **LID
    ),
    "pentagon 5 mm at 0°, lid": dict(pupil_mm=5.0, diaphragm_sides=5, **LID),
    "hexagon 2 mm at 0°, lid": dict(pupil_mm=2.0, diaphragm_sides=6, **LID),
    "octagon 8 mm at 22.5°, lid": dict(
        pupil_mm=8.0, diaphragm_sides=8, diaphragm_rotation_deg=22.5, **LID
    ),
    "hexagon 4 mm at 0°, 4-point cross screen": dict(
        pupil_mm=4.0, diaphragm_sides=6, cross_screen="4-point", **NONE
    ),
    "square 8 mm at 45°, lid, 4-point cross screen": dict(
        pupil_mm=8.0, diaphragm_sides=4, diaphragm_rotation_deg=45.0, cross_screen="4-point",
        **LID,
    ),
    "square 2 mm at 45°, 1000 particles": dict(
        pupil_mm=2.0, diaphragm_sides=4, diaphragm_rotation_deg=45.0,
        **{**NONE, "particles": 1000},
    ),
    "triangle 3 mm at 0°, lid, lashes, 1000 particles": dict(pupil_mm=3.0, diaphragm_sides=3),
}  # fmt: skip


def masks() -> dict[str, np.ndarray]:
    y, x = np.indices(SHAPE) - SHAPE[0] // 2
    radius = np.hypot(x, y) * PIXEL_DEG
    border = np.zeros(SHAPE, bool)
    border[[0, -1], :] = border[:, [0, -1]] = True
    return {"ring 0.2-0.3°": (radius >= 0.2) & (radius < 0.3), "border": border}


def one_sample_kernels(model: WaveOpticsGlare) -> np.ndarray:
    """The model's kernels with every edge drawn by the one-sample cover (the model before)."""
    grid = model.grid_for(PIXEL_DEG, SHAPE)
    acf = aperture_autocorrelation(model._aperture_crop(grid), grid.spacing_mm)
    reach = model._extent_deg(PIXEL_DEG, SHAPE)
    return np.array([
        pixel_integrated_psf(acf, float(w), PIXEL_DEG, SHAPE, reach_deg=reach,
                             edge_transfer=True)
        for w in model._wavelengths()
    ])  # fmt: skip


def fine_exact_kernels(model: WaveOpticsGlare, *, spacing_mm: float = 16.0 / 8192) -> np.ndarray:
    """The aperture drawn on ``spacing_mm``, its pixels integrated exactly."""
    t = model._aperture_crop(ap.ApertureGrid(2 * math.ceil(model.pupil_diameter / spacing_mm) + 9,
                                             spacing_mm))  # fmt: skip
    acf = aperture_autocorrelation(t, spacing_mm)
    reach = model._extent_deg(PIXEL_DEG, SHAPE)
    return np.array([
        pixel_integrated_psf(acf, float(w), PIXEL_DEG, SHAPE, reach_deg=reach,
                             edge_transfer=True)
        for w in model._wavelengths()
    ])  # fmt: skip


def fine_kernels(model: WaveOpticsGlare, *, n: int = 8192, span_mm: float = 16.0) -> np.ndarray:
    spacing = span_mm / n
    t = model._aperture_crop(ap.ApertureGrid(n, spacing))
    field = np.zeros((n, n))
    start = n // 2 - t.shape[0] // 2
    field[start : start + t.shape[0], start : start + t.shape[0]] = t
    spectrum = scipy.fft.fft2(scipy.fft.ifftshift(field))
    del field
    intensity = scipy.fft.fftshift(spectrum.real**2 + spectrum.imag**2)
    del spectrum
    k = np.sinc((np.arange(n) - n // 2) / n) ** 2
    intensity /= k[:, None] * k[None, :] * n * n * t.sum()
    return np.array([
        rebin(intensity, math.degrees(w * 1e-6 / (n * spacing)), PIXEL_DEG, SHAPE)
        for w in model._wavelengths()
    ])  # fmt: skip


def timed(function, *args, repeat: int = 3) -> tuple[object, float]:
    """The result and the shortest of ``repeat`` runs' times (the machine is shared)."""
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = function(*args)
        times.append(time.perf_counter() - start)
    return result, min(times)


def check() -> None:
    """The fine reference against the triangle's exact transform."""
    from tests.glare.models.test_wave_exact import polygon_pixels

    model = WaveOpticsGlare(pupil_mm=3.0, diaphragm_sides=3, **NONE, spectral="reference",
                            spectrum=TWO_WAVELENGTHS)  # fmt: skip
    reference = fine_exact_kernels(model)
    regions = masks()
    everywhere = np.logical_or(*regions.values())
    for i, w in enumerate(model._wavelengths()):
        exact = polygon_pixels(3, 3.0, 0.0, w, PIXEL_DEG, 15, everywhere)
        for name, mask in regions.items():
            print(f"{w:g} nm {name}: {reference[i][mask].sum() / exact[mask].sum() - 1:+.5f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/optics"))
    parser.add_argument("--check", action="store_true", help="only check the reference")
    parser.add_argument("--no-fft", action="store_true", help="leave out the 8192² FFT check")
    args = parser.parse_args()
    if args.check:
        check()
        return
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for case, parameters in CASES.items():
        model = WaveOpticsGlare(**parameters, spectral="reference", spectrum=TWO_WAVELENGTHS)
        before, before_s = timed(one_sample_kernels, model)
        (now, nm), now_s = timed(model.monochromatic_kernels, PIXEL_DEG, SHAPE)
        reference = fine_exact_kernels(model)
        other = None if args.no_fft else fine_kernels(model)
        for i, w in enumerate(nm):
            for name, mask in masks().items():
                ref = reference[i][mask].sum()
                check_ = "" if other is None else f"{other[i][mask].sum() / ref - 1:+.4f}"
                rows.append(
                    {"case": case, "wavelength_nm": f"{w:g}", "region": name,
                     "one_sample": f"{before[i][mask].sum() / ref - 1:+.4f}",
                     "model": f"{now[i][mask].sum() / ref - 1:+.4f}",
                     "reference_check": check_,
                     "one_sample_s": f"{before_s:.3f}", "model_s": f"{now_s:.3f}"}
                )  # fmt: skip
                print(rows[-1], flush=True)
    with open(args.out / "combined_prefilter.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


if __name__ == "__main__":
    main()
