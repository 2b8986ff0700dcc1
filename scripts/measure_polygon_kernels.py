"""Measure polygonal diaphragms' wave kernels against their Fourier transform, ring by ring.

Writes the numbers of docs/optics-departures.md ("wave kernels out to their border",
polygons) as CSV:

    PYTHONPATH=src:. python scripts/measure_polygon_kernels.py --out docs/optics

``polygon_rings.csv``: for 3-8 sides at a rotation that puts a streak on an axis, 2, 5 and
8 mm, 380 and 780 nm, the 0.2-0.3° ring and the border of a 31² kernel at 0.02°/px, model /
reference - 1, with the diaphragm drawn by the one-sample cover (``prefilter=(1, 1)``, the
kernel before, on the grid the kernel asks for) and by the model (its prefilter, and for an
edge along an axis the spacing that puts it a quarter of a sample from the samples). The
reference is the polygon's transform as a sum over its edges, integrated over each pixel by
Gauss-Legendre quadrature
(``tests/glare/models/test_wave_exact.polygon_pixels``).

``polygon_fine.csv``: a third computation, independent of both: the polygon drawn by exactly
clipped cells (each cell's square clipped by the polygon's edges, the shoelace area) on a
grid of 16/8192 mm, zero-padded to 8192², one FFT, the cells' transfer
``sinc²(k/N) sinc²(l/N)`` divided out, the samples rebinned onto the pixels.
"""

from __future__ import annotations

import argparse
import csv
import math
from dataclasses import replace
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
from tests.glare.models.test_wave_exact import polygon_pixels

CAMERA = {"eyelashes": False, "eyelid": False, "particles": 0}
PIXEL_DEG, SHAPE = 0.02, (31, 31)


def masks() -> dict[str, np.ndarray]:
    y, x = np.indices(SHAPE) - SHAPE[0] // 2
    radius = np.hypot(x, y) * PIXEL_DEG
    border = np.zeros(SHAPE, bool)
    border[[0, -1], :] = border[:, [0, -1]] = True
    return {"ring 0.2-0.3°": (radius >= 0.2) & (radius < 0.3), "border": border}


def axis_rotation_deg(sides: int) -> float:
    """A rotation that puts an edge's normal, and so its streak, on an axis."""
    return 0.0 if sides % 2 else 90.0 - 180.0 / sides


def box_kernels(model: WaveOpticsGlare) -> tuple[np.ndarray, np.ndarray]:
    """The model's kernels with the diaphragm drawn by the one-sample cover (the kernel before),
    on the grid the kernel asks for: a round pupil's, without the quarter-sample lock of a
    polygon's axis edges (``WaveOpticsGlare._diaphragm_phase_spacing``)."""
    grid = replace(model, diaphragm_sides=None).grid_for(PIXEL_DEG, SHAPE)
    crop = ap.ApertureGrid(
        2 * (math.ceil(model.pupil_diameter / 2 / grid.spacing_mm) + 2) + 1, grid.spacing_mm
    )
    t = ap.aperture_diaphragm(
        crop,
        model.pupil_diameter,
        model.diaphragm_sides,
        rotation_deg=model.diaphragm_rotation_deg,
    )
    acf = aperture_autocorrelation(t, grid.spacing_mm)
    nm = model.monochromatic_kernels(PIXEL_DEG, SHAPE)[1]
    reach = model._extent_deg(PIXEL_DEG, SHAPE)
    kernels = [
        pixel_integrated_psf(acf, w, PIXEL_DEG, SHAPE, reach_deg=reach, edge_transfer=True)
        for w in nm
    ]
    return np.array(kernels), nm


def _clip(polygon, normal, apothem):
    out = []
    for p, q in zip(polygon, polygon[1:] + polygon[:1], strict=True):
        fp = normal[0] * p[0] + normal[1] * p[1] - apothem
        fq = normal[0] * q[0] + normal[1] * q[1] - apothem
        if fp <= 0:
            out.append(p)
        if fp * fq < 0:
            s = fp / (fp - fq)
            out.append((p[0] + s * (q[0] - p[0]), p[1] + s * (q[1] - p[1])))
    return out


def _shoelace(polygon) -> float:
    if len(polygon) < 3:
        return 0.0
    pairs = zip(polygon, polygon[1:] + polygon[:1], strict=True)
    return abs(sum(p[0] * q[1] - q[0] * p[1] for p, q in pairs)) / 2


def clipped_polygon(sides, diameter_mm, rotation_deg, spacing_mm, m) -> np.ndarray:
    """``(m, m)`` cover of each cell by the polygon, sample ``(i, j)`` at
    ``x = (j - m//2) δ``, ``y = (m//2 - i) δ``: cells near an edge clipped exactly."""
    angles = math.radians(rotation_deg) + (np.arange(sides) + 0.5) * 2 * math.pi / sides
    normals = [(math.cos(a), math.sin(a)) for a in angles]
    apothem = diameter_mm / 2 * math.cos(math.pi / sides)
    axis = (np.arange(m) - m // 2) * spacing_mm
    x, y = np.meshgrid(axis, -axis)
    distance = np.min([apothem - (x * c + y * s) for c, s in normals], axis=0)
    t = (distance > 0).astype(float)
    h = spacing_mm / 2
    for i, j in zip(*np.nonzero(np.abs(distance) <= spacing_mm), strict=True):
        cx, cy = x[i, j], y[i, j]
        cell = [(cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)]
        for normal in normals:
            cell = _clip(cell, normal, apothem)
        t[i, j] = _shoelace(cell) / spacing_mm**2
    return t


def fine_kernels(sides, diameter_mm, rotation_deg, wavelengths, *, n=8192, span_mm=16.0):
    spacing = span_mm / n
    m = 2 * math.ceil(diameter_mm / 2 / spacing + 2) + 1
    t = clipped_polygon(sides, diameter_mm, rotation_deg, spacing, m)
    field = np.zeros((n, n))
    start = n // 2 - m // 2
    field[start : start + m, start : start + m] = t
    spectrum = scipy.fft.fft2(scipy.fft.ifftshift(field))
    del field
    intensity = scipy.fft.fftshift(spectrum.real**2 + spectrum.imag**2)
    del spectrum
    k = np.sinc((np.arange(n) - n // 2) / n) ** 2
    intensity /= k[:, None] * k[None, :] * n * n * t.sum()
    return [
        rebin(intensity, math.degrees(w * 1e-6 / (n * spacing)), PIXEL_DEG, SHAPE)
        for w in wavelengths
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/optics"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    regions = masks()
    everywhere = np.logical_or(*regions.values())
    rows = []
    for sides in range(3, 9):
        for diameter in (2.0, 5.0, 8.0):
            rotation = axis_rotation_deg(sides)
            model = WaveOpticsGlare(
                pupil_mm=diameter, **CAMERA, diaphragm_sides=sides,
                diaphragm_rotation_deg=rotation,
                spectrum=Spectrum(n_wavelengths=2, wavelength_range_nm=(380.0, 780.0)),
            )  # fmt: skip
            now, nm = model.monochromatic_kernels(PIXEL_DEG, SHAPE)
            before, _ = box_kernels(model)
            for i, w in enumerate(nm):
                reference = polygon_pixels(sides, diameter, rotation, w, PIXEL_DEG, 15, everywhere)
                for name, mask in regions.items():
                    ref = reference[mask].sum()
                    rows.append(
                        {"sides": sides, "diameter_mm": diameter, "rotation_deg": rotation,
                         "wavelength_nm": w, "region": name,
                         "box_cover": f"{before[i][mask].sum() / ref - 1:+.5f}",
                         "prefilter": f"{now[i][mask].sum() / ref - 1:+.5f}"}
                    )  # fmt: skip
            print(rows[-1], flush=True)
    with open(args.out / "polygon_rings.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    fine_rows = []
    for sides, diameter, rotation in ((3, 3.0, 0.0), (6, 4.0, 0.0), (4, 2.0, 45.0)):
        model = WaveOpticsGlare(
            pupil_mm=diameter, **CAMERA, diaphragm_sides=sides,
            diaphragm_rotation_deg=rotation, spectral="kakimoto",
        )  # fmt: skip
        now, nm = model.monochromatic_kernels(PIXEL_DEG, SHAPE)
        before, _ = box_kernels(model)
        fine = fine_kernels(sides, diameter, rotation, nm)
        for i, w in enumerate(nm):
            reference = polygon_pixels(sides, diameter, rotation, w, PIXEL_DEG, 15, everywhere)
            for name, mask in regions.items():
                ref = reference[mask].sum()
                fine_rows.append(
                    {"sides": sides, "diameter_mm": diameter, "rotation_deg": rotation,
                     "wavelength_nm": w, "region": name,
                     "fine_fft": f"{fine[i][mask].sum() / ref - 1:+.5f}",
                     "box_cover": f"{before[i][mask].sum() / ref - 1:+.5f}",
                     "prefilter": f"{now[i][mask].sum() / ref - 1:+.5f}"}
                )  # fmt: skip
        print(fine_rows[-1], flush=True)
    with open(args.out / "polygon_fine.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(fine_rows[0]))
        writer.writeheader()
        writer.writerows(fine_rows)


if __name__ == "__main__":
    main()
