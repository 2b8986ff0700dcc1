"""``glarelab bench``: what each speed knob costs in accuracy, in display codes.

For each workload and model a float64 reference is rendered with generous settings (the exact
render: full-reach kernel, full resolution, and for the Vos PSF 4× the default integration
samples). Every variant is timed in this process, the contenders interleaved (one run of each
in turn, ``repeats`` rounds, the best kept), with the kernel digitised beforehand for every
one of them (a stimulus set renders many images with one kernel): our renderers are built
and run once before timing, the peers get the digitised kernel. One row, ``add_glare, one
call``, pays the digitisation. Errors are in codes of the shipped 10-bit, 433 cd/m²
synthetic display (continuous codes through its calibration: 0.5 is half a step).

Ratios to the peers are the median over the rounds of the ratio of the two times measured in
the same round. The floor, one padded ``rfft2`` and ``irfft2`` pair in float32 (no glare), is
timed on every workload: what any whole-image FFT render pays at least.

Peers, timed in the same run: ``irfft2(rfft2(ΔL) · K̂)`` with the kernel's spectrum computed
once (the best a user could write with ``scipy.fft``; float64, and float32 where it stays
within half a code); ``scipy.signal.fftconvolve`` of the whole excess image with the full
kernel; for the Gaussian ``scipy.ndimage.gaussian_filter`` and OpenCV's ``GaussianBlur``
(when ``cv2`` is installed), each truncated at 4-6 σ.

Workloads (:data:`WORKLOADS`): the Yoshida 2008 stimulus at the paper's display geometry; a
1280 × 1024 night scene with six headlights (Spencer Fig. 14); a 1024² city at night with
2,000 lamps, a 1024² RGB street with 200 sodium and white lamps and a 1024² sky with the sun
(issue 35); a 256² street with a few
lamps and a 4096 × 256 strip; 2048² scenes at 40°: a 7.5e8 cd/m² sun disk over a
displayable landscape, the Fig. 16 tree against a 4000 cd/m² sky with the sun through three
holes, water with glints (many bright pixels all over), a city at night with 300 lamps
(luminance and RGB), and a night scene with a sun-bright glint and three lamps; ``large``
adds the 4096² versions. Peak memory of a 2048² render is measured in separate processes.
The spectral section times the wave-optics PSF's ``scaled`` copies against one FFT per
wavelength, with CIEDE2000.
"""

from __future__ import annotations

import csv
import functools
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from glarelab import glare
from glarelab.bench.peers import (
    FLOOR,
    PEER,
    PEER_SPECTRUM,
    PEER_SPECTRUM_32,
    fftconvolve_peer,
    floor_peer,
    gaussian_peers,
    spectrum_peer,
)
from glarelab.bench.processes import (
    FRESH_WORKLOADS,
    MEMORY_WORKLOADS,
    fresh_bench,
    memory_bench,
    startup_bench,
)
from glarelab.bench.report import DEFAULT, tables, write_plots
from glarelab.bench.scenes import (
    CALIBRATION,
    L_DMAX,
    MODELS,
    WORKLOADS,
    bench_model,
    workload,
    workload_names,
)
from glarelab.bench.spectral import spectral_bench
from glarelab.bench.timing import round_ratio, timed
from glarelab.display.calibration import Calibration
from glarelab.files.atomic import atomic_open, write_text
from glarelab.glare.models.digitise import kernel_shape_for
from glarelab.glare.rendering.costs import measure_costs
from glarelab.glare.rendering.display import display_codes

__all__ = ["run_bench"]


@functools.cache
def _machine_costs():
    """The path costs of this machine, measured once per run (the renderers have no cache)."""
    return measure_costs()


def _reach_shape(reach_deg: float, pixel: float, full: tuple[int, int]) -> tuple[int, int]:
    return tuple(min(2 * round(reach_deg / pixel / 2) + 1, f) for f in full)


class _Prepared:
    """A renderer for ``image``, built and run once (what a stimulus set reuses); calling it
    renders again and notes the path taken."""

    def __init__(self, model, image, pixel, lut, **options) -> None:
        self.renderer = glare.GlareRenderer(
            model,
            pixel_deg=pixel,
            shape=image.shape,
            l_dmax_cd_m2=L_DMAX,
            display=lut,
            cache=False,
            costs=_machine_costs(),
            **options,
        )
        self.image = image
        self()

    def __call__(self) -> np.ndarray:
        result = self.renderer.render(self.image)
        self.path = result.plan.path + (" (fallback)" if result.fallback else "")
        self.transforms = (
            result.plan.fft_precision if result.plan.path in ("fft", "multires") else ""
        )
        return result.image


def _variants(image, pixel, model, lut, kernel) -> dict[str, Callable[[], np.ndarray]]:
    full = kernel_shape_for(image.shape)
    given = {"kernel": kernel}

    def prepared(chosen=model, **options):
        kernel_given = given if chosen is model and "kernel_shape" not in options else {}
        return _Prepared(chosen, image, pixel, lut, **kernel_given, **options)

    variants = {
        DEFAULT: prepared(),
        "add_glare, one call (kernel digitised)": lambda: glare.add_glare(
            image, model, pixel_deg=pixel, l_dmax_cd_m2=L_DMAX, display=lut, cache=False
        ),
        "plan, 2 codes": prepared(tolerance_codes=2.0),
        "plan, 0.1 codes": prepared(tolerance_codes=0.1),
        "float32": prepared(precision="float32"),
        "path: fft only": prepared(paths=("fft",)),
        "path: multires only": prepared(paths=("multires",)),
        "exact (full kernel, full resolution)": prepared(tolerance_codes=0),
    }
    bright = image > L_DMAX
    bright = int(np.count_nonzero(bright.any(axis=2) if image.ndim == 3 else bright))
    if bright * image.shape[0] * image.shape[1] <= DIRECT_LIMIT:
        variants["path: direct only"] = prepared(paths=("direct",))
    if isinstance(model, glare.VosGlare):
        for label, samples in (("samples 2/10", (2, 10)), ("samples 5/50", (5, 50))):
            coarser = replace(
                model, samples_per_pixel=samples[0], center_samples_per_pixel=samples[1]
            )
            variants[label] = prepared(coarser)
    for reach in (1.0, 4.0):
        shape = _reach_shape(reach, pixel, full)
        if shape != full:
            variants[f"fixed reach {reach:g}°"] = prepared(kernel_shape=shape, tolerance_codes=0)
    values = kernel.values
    if values.ndim == 3 and model.achromatic:  # one kernel for the three channels
        values = values[..., 0]
    variants[PEER_SPECTRUM] = spectrum_peer(image, values, np.float64)
    variants[PEER_SPECTRUM_32] = spectrum_peer(image, values, np.float32)
    variants[PEER] = fftconvolve_peer(image, values)
    variants[FLOOR] = floor_peer(image)
    if isinstance(model, glare.GaussianGlare):
        variants.update(gaussian_peers(image, pixel, model))
    return variants


DIRECT_LIMIT = 2e9  # multiply-adds up to which the direct path alone is timed


def _reference(image, pixel, model):
    if isinstance(model, glare.VosGlare):
        finer = {  # the halo's spacing only where there is a halo (else refused as idle)
            "samples_per_pixel": 4 * model.samples_per_pixel,
            "center_samples_per_pixel": 4 * model.center_samples_per_pixel,
        }
        if model.weights[3] > 0:
            finer["halo_spacing_deg"] = model.halo_spacing_deg / 4
        model = replace(model, **finer)
    return glare.add_glare(image, model, pixel_deg=pixel, tolerance_codes=None)


def run_bench(
    out: str | Path,
    *,
    large: bool = False,
    only: tuple[str, ...] | None = None,
    spectral: bool = True,
    repeats: int = 3,
    fresh: bool = True,
    startup: bool = True,
    log=print,
) -> list[dict]:
    """Run the benchmark; write ``bench.csv``, ``bench.md`` and one Pareto PNG per workload
    (and ``memory.csv`` when a workload of :data:`MEMORY_WORKLOADS` is run, ``startup.csv``
    with the start-up times).

    Parameters
    ----------
    out
        Directory for the results.
    large
        Add the 4096² scenes.
    only
        Run only these workloads (names of :data:`WORKLOADS`).
    spectral
        Also run :func:`spectral_bench`.
    fresh
        Time the one-call workload (:data:`FRESH_WORKLOADS`) in fresh processes, with an
        empty and a warm kernel cache (:func:`fresh_bench`).
    startup
        Time the start-up (:func:`startup_bench`).
    repeats
        Rounds of timings (the contenders in turn); the best is reported.
    log
        Called with one line per step.
    """

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    lut = Calibration.load(CALIBRATION).lut
    names = workload_names(large) if only is None else list(only)
    unknown = sorted(set(names) - set(WORKLOADS))
    if unknown:
        raise ValueError(f"unknown workloads {unknown}; choose from {sorted(WORKLOADS)}")
    rows = []
    for number, name in enumerate(names, start=1):
        image, pixel = workload(name)
        for model_name in MODELS[name]:
            model = bench_model(model_name, pixel)
            label = f"[{number}/{len(names)}] {name} / {model_name}"
            log(f"{label}: {image.shape[1]} × {image.shape[0]} px at {pixel:.4g}°/px")
            reference_codes = display_codes(_reference(image, pixel, model), lut)
            kernel = model.kernel(pixel, kernel_shape_for(image.shape), colour=image.ndim == 3)
            variants = _variants(image, pixel, model, lut, kernel)
            results = []
            rounds: dict = {}
            measured = timed(variants, repeats, rounds=rounds)
            if fresh and name in FRESH_WORKLOADS:
                measured |= fresh_bench(name, model_name, repeats, log=log)
            for variant, (seconds, result) in measured.items():
                error = np.abs(display_codes(result, lut) - reference_codes)
                results.append(
                    {
                        "workload": name,
                        "model": model_name,
                        "variant": variant,
                        "seconds": seconds,
                        "max_error_codes": float(error.max()),
                        "rms_error_codes": float(np.sqrt(np.mean(error**2))),
                        "path": getattr(variants.get(variant), "path", ""),
                        "transforms": getattr(variants.get(variant), "transforms", ""),
                    }
                )
                log(f"  {variant}: {seconds:.3f} s, max error {error.max():.3g} codes")
            by_variant = {r["variant"]: r["seconds"] for r in results}
            for r in results:
                # median of the per-round ratios where both ran in the same rounds
                for column, peer in (
                    ("speed_vs_peer", PEER),
                    ("speed_vs_spectrum_peer", PEER_SPECTRUM),
                    ("speed_vs_spectrum_peer_32", PEER_SPECTRUM_32),
                    ("speed_vs_floor", FLOOR),
                ):
                    if r["variant"] in rounds:
                        r[column] = round_ratio(rounds, peer, r["variant"])
                    else:  # timed in fresh processes: against the best of the rounds
                        r[column] = by_variant[peer] / r["seconds"]
            rows += results
    memory_rows = []
    for name in (n for n in names if n in MEMORY_WORKLOADS):
        log(f"peak memory: {name}")
        memory_rows += memory_bench(name, log=log)
    spectral_rows = []
    if spectral:
        log("wave-optics PSF: scaled copies against one FFT per wavelength")
        spectral_rows = spectral_bench(repeats=1)
        for r in spectral_rows:
            log(f"  {r['variant']}: {r['seconds']:.2f} s, ΔE00 {r['delta_e_mean']:.3g}")
    startup_rows = []
    if startup:
        log("start-up: imports and processes against import numpy, scipy.fft")
        startup_rows = startup_bench(repeats=repeats, log=log)
    write_plots(rows, out)
    for file, table in (
        ("bench.csv", rows),
        ("spectral.csv", spectral_rows),
        ("memory.csv", memory_rows),
        ("startup.csv", startup_rows),
    ):
        if table:
            with atomic_open(out / file, "w", newline="") as handle:
                writer = csv.DictWriter(handle, fieldnames=list(table[0]))
                writer.writeheader()
                writer.writerows(table)
    write_text(out / "bench.md", tables(rows, spectral_rows, memory_rows, startup_rows))
    return rows + spectral_rows + memory_rows + startup_rows
