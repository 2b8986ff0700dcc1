"""``glarelab bench``: what each speed knob costs in accuracy, in display codes.

For each workload a float64 reference is rendered with generous settings (full reach kernel,
4× the default integration samples); every variant is timed (median of repeats, in this
process, kernel digitisation included: what a user pays) and compared with it in the codes of
the shipped 10-bit, 433 cd/m² synthetic display (continuous codes through its calibration, so
0.5 means half a step). The peer, ``scipy.signal.fftconvolve`` of the whole excess image with
the full kernel, is timed in the same run and every time is also given as a ratio to it.

Workloads: the Yoshida 2008 stimulus at the paper's display geometry (disk at level F,
7000 cd/m²), and a 1280 × 1024 night scene with six light sources (Spencer Fig. 14 style);
with ``large``, a 2048² sky (4000 cd/m²) with a 7.5e8 cd/m² sun (Spencer Fig. 16).
"""

from __future__ import annotations

import csv
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.signal import fftconvolve

import glare
from glare.digitise import kernel_shape_for
from stimuli.calibration import Calibration

__all__ = ["run_bench", "workloads"]

CALIBRATION = (
    Path(__file__).resolve().parents[1] / "calibrations" / "SYNTHETIC-yoshida2008-433cd-10bit.json"
)
L_DMAX = 220.0


def workloads(large: bool = False) -> dict[str, tuple[np.ndarray, float]]:
    """name → (luminance image, pixel_deg)."""
    rng = np.random.default_rng(0)
    loads = {}
    n = 271  # Yoshida: 3.2° at 0.011824°/px
    y, x = np.indices((n, n)) - n // 2
    disk = np.hypot(x, y) * 0.011824 <= 0.15  # the 0.3° disk
    sky = np.clip(150 + 15 * rng.standard_normal((n, n)), 0, 200)
    loads["yoshida2008"] = (np.where(disk, 7000.0, sky), 0.011824)
    night = np.full((1024, 1280), 0.05) + 0.02 * rng.random((1024, 1280))
    for row, col, level in (
        (400, 300, 2e4),
        (405, 340, 2e4),
        (600, 900, 8e4),
        (610, 960, 8e4),
        (300, 1100, 5e3),
        (800, 200, 1e5),
    ):
        night[row - 2 : row + 3, col - 2 : col + 3] = level
    loads["night_1280x1024"] = (night, 0.03)
    if large:
        m = 2048
        sky = np.full((m, m), 4000.0)
        yy, xx = np.indices((m, m)) - m // 2
        sky[np.hypot(xx, yy) <= 3] = 7.5e8
        loads["sun_2048"] = (sky, 0.01)
    return loads


def _codes(image: np.ndarray, lut: np.ndarray) -> np.ndarray:
    return np.interp(np.clip(image, lut[0], lut[-1]), lut, np.arange(lut.size, dtype=float))


def _timed(function: Callable[[], np.ndarray], repeats: int) -> tuple[float, np.ndarray]:
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def _variants(image: np.ndarray, pixel: float) -> dict[str, Callable[[], np.ndarray]]:
    full = kernel_shape_for(image.shape)
    reach = {
        f"reach {d:g}°": tuple(min(2 * round(d / pixel / 2) + 1, f) for f in full)
        for d in (1.0, 2.0, 4.0)
    }

    def vos(**options):
        shape = options.pop("shape", full)
        precision = options.pop("precision", "float64")
        return lambda: glare.add_glare(
            image,
            glare.VosGlare(**options),
            pixel_deg=pixel,
            kernel_shape=shape,
            precision=precision,
        )

    variants = {
        "default (10/100 samples, full reach, float64)": vos(),
        "float32": vos(precision="float32"),
        "samples 2/10": vos(samples_per_pixel=2, center_samples_per_pixel=10),
        "samples 5/50": vos(samples_per_pixel=5, center_samples_per_pixel=50),
    }
    for name, shape in reach.items():
        if shape != full:
            variants[name] = vos(shape=shape)

    def peer():
        kernel = glare.VosGlare().kernel(pixel, full).values
        excess = np.maximum(image - L_DMAX, 0.0)
        spread = fftconvolve(excess, kernel, mode="same")
        return np.minimum(image + spread, L_DMAX)

    variants["peer: scipy fftconvolve, whole image, full kernel"] = peer
    return variants


def run_bench(out: str | Path, *, large: bool = False, repeats: int = 3, log=print) -> list[dict]:
    """Run the benchmark; write ``bench.csv``, ``bench.md`` and one Pareto PNG per workload."""
    from analysis.figures import plt, png

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    lut = Calibration.load(CALIBRATION).lut
    rows = []
    for name, (image, pixel) in workloads(large).items():
        log(f"workload {name}: {image.shape[1]} × {image.shape[0]} px at {pixel:g}°/px")
        reference = glare.add_glare(
            image,
            glare.VosGlare(samples_per_pixel=20, center_samples_per_pixel=200),
            pixel_deg=pixel,
        )
        reference_codes = _codes(reference, lut)
        results = []
        for label, function in _variants(image, pixel).items():
            seconds, result = _timed(function, repeats)
            error = np.abs(_codes(result, lut) - reference_codes)
            results.append(
                {
                    "workload": name,
                    "variant": label,
                    "seconds": seconds,
                    "max_error_codes": float(error.max()),
                    "rms_error_codes": float(np.sqrt(np.mean(error**2))),
                }
            )
            log(f"  {label}: {seconds:.3f} s, max error {error.max():.3g} codes")
        peer = next(r["seconds"] for r in results if r["variant"].startswith("peer"))
        for r in results:
            r["speed_vs_peer"] = peer / r["seconds"]
        rows += results
        figure, axis = plt.subplots(figsize=(6.5, 4))
        for r in results:
            axis.scatter(r["seconds"], max(r["max_error_codes"], 1e-6), s=25)
            axis.annotate(
                r["variant"].split(" (")[0],
                (r["seconds"], max(r["max_error_codes"], 1e-6)),
                fontsize=7,
            )
        axis.axhline(0.5, color="k", ls="--", lw=0.8, label="half a display code")
        axis.set(
            xscale="log",
            yscale="log",
            xlabel="time (s, median)",
            ylabel="max error (10-bit codes)",
            title=f"{name}: time against error",
        )
        axis.legend(fontsize=7)
        (out / f"pareto_{name}.png").write_bytes(png(figure))
    with (out / "bench.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "| workload | variant | time (s) | × peer speed | max error (codes) | RMS (codes) |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    lines += [
        f"| {r['workload']} | {r['variant']} | {r['seconds']:.3f} | {r['speed_vs_peer']:.2f} | "
        f"{r['max_error_codes']:.3g} | {r['rms_error_codes']:.3g} |"
        for r in rows
    ]
    (out / "bench.md").write_text("\n".join(lines) + "\n")
    return rows
