"""Measure wave-optics kernels: exact pixel integration against FFT samples rebinned, the cost
of each, and the two pupil conventions. Writes the tables of docs/speed-accuracy.md
("Wave-optics kernels") and docs/optics-departures.md ("The pupil") as CSV and Markdown.

    PYTHONPATH=. python scripts/measure_wave_kernels.py --out docs/bench-wave

The reference is the Airy pattern of a circular pupil integrated over each pixel by
Gauss-Legendre quadrature (independent of the model's DFT); the errors are the centre pixel's
relative error and the largest pixel error over the peak pixel. Times are the best of three
calls, with the BLAS's default threads and (exact) with one BLAS thread, which on a loaded
machine is faster for these small matrix products; memory is the peak of Python-visible
allocations (tracemalloc, which numpy reports to).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import time
import tracemalloc
from pathlib import Path

import numpy as np
from scipy.special import j1

from glarelab.glare import WaveOpticsGlare

CAMERA = {"eyelashes": False, "eyelid": False, "particles": 0}


def airy_pixels(diameter_mm: float, wavelength_nm: float, pixel_deg: float, half: int):
    """The Airy pattern integrated over the pixels of a ``(2 half + 1)²`` kernel."""
    lam = wavelength_nm * 1e-6
    p = math.radians(pixel_deg)
    n = 16 + 2 * math.ceil(6 * p * diameter_mm / lam)
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = x / 2, w / 2
    peak = math.pi * (diameter_mm / 2) ** 2 / lam**2
    quadrant = np.empty((half + 1, half + 1))
    for i in range(half + 1):
        ty = (i + x[:, None]) * p
        for j in range(i, half + 1):
            tx = (j + x[None, :]) * p
            a = math.pi * diameter_mm * np.hypot(tx, ty) / lam
            safe = np.where(a > 1e-9, a, 1.0)
            density = peak * np.where(a > 1e-9, (2 * j1(safe) / safe) ** 2, 1.0)
            quadrant[i, j] = quadrant[j, i] = np.sum(w[:, None] * w[None, :] * density) * p * p
    rows = np.concatenate([quadrant[:0:-1], quadrant], axis=0)
    return np.concatenate([rows[:, :0:-1], rows], axis=1)


def errors(out: Path) -> list[dict]:
    rows = []
    for pixel_deg in (0.0005, 0.002, 0.0118, 0.05):
        half = 10
        reference = airy_pixels(3.0, 530.0, pixel_deg, half)
        for integration in ("rebin", "exact"):
            model = WaveOpticsGlare(
                pupil_mm=3.0, **CAMERA, spectral="kakimoto", pixel_integration=integration
            )
            kernel = model.monochromatic_kernels(pixel_deg, (2 * half + 1,) * 2)[0][1]
            rows.append(
                {
                    "pixel_deg": pixel_deg,
                    "integration": integration,
                    "centre": kernel[half, half],
                    "centre_reference": reference[half, half],
                    "centre_error_pct": 100 * (kernel[half, half] / reference[half, half] - 1),
                    "worst_error_pct_of_peak": 100
                    * np.abs(kernel - reference).max()
                    / reference.max(),
                }
            )
    _write(out / "wave_errors.csv", rows)
    return rows


CASES = {
    "3 mm camera pupil, 101² at 0.0118°/px": (
        {"pupil_mm": 3.0, **CAMERA},
        0.0118,
        (101, 101),
    ),
    "6 mm eye, lashes, lid, 1000 particles, 201² at 0.01°/px": (
        {"pupil_mm": 6.0, "particles": 1000},
        0.01,
        (201, 201),
    ),
    "8 mm pupil, 1000 particles, 201² at 0.01°/px": (
        {"pupil_mm": 8.0, "eyelashes": False, "eyelid": False, "particles": 1000},
        0.01,
        (201, 201),
    ),
}


def costs(out: Path) -> list[dict]:
    from threadpoolctl import threadpool_limits

    rows = []
    for name, (options, pixel_deg, shape) in CASES.items():
        for integration, blas in (("rebin", None), ("exact", None), ("exact", 1)):
            model = WaveOpticsGlare(**options, pixel_integration=integration)
            seconds = []
            with threadpool_limits(blas, user_api="blas"):
                for _ in range(3):
                    start = time.perf_counter()
                    model.kernel(pixel_deg, shape)
                    seconds.append(time.perf_counter() - start)
                tracemalloc.start()
                model.kernel(pixel_deg, shape)
                peak = tracemalloc.get_traced_memory()[1]
                tracemalloc.stop()
            grid = model.grid_for(pixel_deg, shape)
            rows.append(
                {
                    "case": name,
                    "integration": integration,
                    "blas_threads": "default" if blas is None else blas,
                    "seconds": min(seconds),
                    "peak_mb": peak / 2**20,
                    "grid": grid.n,
                    "pupil_samples": round(model.pupil_diameter / grid.spacing_mm),
                }
            )
            print(f"{name} {integration} {blas}: {min(seconds):.2f} s, {peak / 2**20:.0f} MB")
            _write(out / "wave_costs.csv", rows)  # each row as it is measured
    _write(out / "wave_costs.csv", rows)
    return rows


def pupils(out: Path) -> list[dict]:
    rows = []
    pixel_deg, shape = 0.01, (201, 201)
    y, x = np.indices(shape) - shape[0] // 2
    radius = np.hypot(x, y) * pixel_deg
    for convention in ("unit-energy", "Luidolt2020"):
        for pupil_mm in (2.0, 4.0, 6.0, 8.0):
            model = WaveOpticsGlare(
                pupil_mm=pupil_mm, eyelashes=False, eyelid=False, particles=1000,
                pupil_convention=convention,
            )  # fmt: skip
            k = model.kernel(pixel_deg, shape).values
            rows.append(
                {
                    "convention": convention,
                    "pupil_mm": pupil_mm,
                    "kernel_energy": k.sum(),
                    "beyond_0.05_deg": k[radius > 0.05].sum(),
                    "beyond_0.1_deg": k[radius > 0.1].sum(),
                    "beyond_0.5_deg": k[radius > 0.5].sum(),
                }
            )
    _write(out / "wave_pupils.csv", rows)
    return rows


CORE_VARIANTS = {
    "eye (lashes and lid)": {},
    "lid, no lashes": {"eyelashes": False},
    "lashes, no lid": {"eyelid": False},
    "pupil only": {"eyelashes": False, "eyelid": False},
}


def core(out: Path) -> list[dict]:
    """The glare_methods2026 'kakimoto' eye (5 mm pupil, seed 2026, 0.0118°/px) with its
    obstacles taken away one at a time: the aperture, the kernel's contours, and the
    elongation (axis ratio and direction of the second moments) of the kernel above 1 % and
    0.1 % of its peak, the levels a 10,000 cd/m² disk saturates on a 220 cd/m² display."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pixel_deg, shape = 0.011824, (61, 61)
    figure, axes = plt.subplots(2, len(CORE_VARIANTS), figsize=(13, 6.6))
    rows = []
    for column, (name, options) in enumerate(CORE_VARIANTS.items()):
        model = WaveOpticsGlare(
            pupil_mm=5.0, particles=0, seed=2026, spectral="kakimoto", **options
        )
        grid = model.grid_for(pixel_deg, shape)
        aperture = model._aperture_crop(grid)
        kernel = model.kernel(pixel_deg, shape).values
        extent = aperture.shape[0] * grid.spacing_mm / 2
        axes[0, column].imshow(aperture, cmap="gray", extent=(-extent, extent, -extent, extent))
        axes[0, column].set_title(name)
        axes[0, column].set_xlabel("mm")
        half = shape[0] // 2 * pixel_deg
        axes[1, column].imshow(
            np.log10(np.maximum(kernel / kernel.max(), 1e-5)),
            cmap="magma", vmin=-5, vmax=0, extent=(-half, half, -half, half),
        )  # fmt: skip
        axes[1, column].contour(
            np.linspace(-half, half, shape[1]), np.linspace(half, -half, shape[0]),
            kernel / kernel.max(), levels=[1e-3, 1e-2], colors=["cyan", "white"],
        )  # fmt: skip
        axes[1, column].set_xlabel("degrees")
        for level in (1e-2, 1e-3):
            ratio, angle = _elongation(kernel, level)
            rows.append(
                {"aperture": name, "level": level, "axis_ratio": ratio, "major_axis_deg": angle}
            )
        axes[1, column].set_title(
            f"{rows[-1]['axis_ratio']:.2f}:1 at 0.1 %, {rows[-1]['major_axis_deg']:.0f}°"
        )
    axes[0, 0].set_ylabel("aperture (y up)")
    axes[1, 0].set_ylabel("kernel, log10 of peak; contours 1 %, 0.1 %")
    figure.tight_layout()
    tmp = out / "kakimoto_core.tmp.png"
    figure.savefig(tmp, dpi=90)
    plt.close(figure)
    os.replace(tmp, out / "kakimoto_core.png")
    _write(out / "kakimoto_core.csv", rows)
    return rows


def _elongation(kernel: np.ndarray, level: float) -> tuple[float, float]:
    """Axis ratio and direction (degrees anticlockwise from +x, y up) of the second moments
    of the kernel where it is at ``level`` of its peak or above."""
    y, x = np.indices(kernel.shape) - kernel.shape[0] // 2
    y = -y
    w = np.where(kernel >= level * kernel.max(), kernel, 0.0)
    cov = np.array(
        [[(w * x * x).sum(), (w * x * y).sum()], [(w * x * y).sum(), (w * y * y).sum()]]
    )
    values, vectors = np.linalg.eigh(cov / w.sum())
    angle = math.degrees(math.atan2(vectors[1, 1], vectors[0, 1])) % 180
    return float(math.sqrt(values[1] / values[0])), angle


def _write(path: Path, rows: list[dict]) -> None:
    tmp = path.with_suffix(".tmp")
    with tmp.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for row in rows:
            writer.writerow({k: f"{v:.6g}" if isinstance(v, float) else v for k, v in row.items()})
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/bench-wave"))
    parser.add_argument("--only", choices=("errors", "costs", "pupils", "core"), action="append")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    chosen = args.only or ["errors", "costs", "pupils", "core"]
    for what in chosen:
        rows = {"errors": errors, "costs": costs, "pupils": pupils, "core": core}[what](args.out)
        for row in rows:
            print({k: f"{v:.4g}" if isinstance(v, float) else v for k, v in row.items()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
