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
  divided out (the model before; now only with lashes or particles, which it keeps);
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

``--sweep`` prints a square diaphragm at 45° alone (its edges along the axes), of side
2.000-2.050 mm in steps of 0.005 mm (edges swept over two samples of the grid) and with its
edges exactly on a sample and half-way between two, at 380 nm
against its transform: the border and the 0.2-0.3° ring under (5, 3), (5, 4) and (7, 4),
the transfer divided out at each pixel's centre or over fifths, under (5, 3) on a grid
whose spacing puts the edges a quarter of a sample from the samples, and on the model's grid
(``WaveOpticsGlare._diaphragm_phase_spacing``: the same lock, at ``m + 1/4`` or ``m + 3/4``
samples).

``--only CASE ...`` reruns those cases of ``combined_prefilter.csv`` and keeps its other rows.

``--others`` writes ``others_prefilter.csv`` instead: the apertures that kept the one-sample
cover until they were measured (a round pupil behind the lid alone, a round pupil behind a
4-point screen, a trigonal cross screen, an obstacle image), the same regions and
wavelengths:

- ``one_sample``: the one-sample cover (a bitmap read as each sample's cell cover);
- ``interpolated``: for an obstacle image, the model before (the bitmap linearly interpolated
  onto the grid);
- ``prefilter``: the whole aperture under ``DIAPHRAGM_PREFILTER``, (5, 3)
  (``apertures.aperture_diaphragm_prefiltered``, a round pupil with ``sides=None``), on the
  grid the kernel asks for, its transfer divided out at each pixel's centre (for an obstacle
  image, the model before its grid was locked to the image's pixels);
- ``trigonal_prefilter``: the same under ``TRIGONAL_PREFILTER``, (3, 2), 25 sub-cells;
- ``model``: the model (which prefilter it uses: ``model_uses``; for an obstacle image the
  grid spacing ``2 s / m``, ``m`` odd, that puts the image's pixel edges a quarter of a sample
  from the samples, and the transfer divided out over fifths of each pixel:
  ``WaveOpticsGlare._image_phase_spacing``, ``IMAGE_TRANSFER_PARTS``);
- ``before_s``, ``model_s``: the time of the model before (the one-sample cover; for an
  image, the interpolation) and of the model, two wavelengths, the shortest of three runs;
  ``prefilter_s``: for an image, the time of ``prefilter``;
- ``reference``: ``fine`` as above, or ``bitmap``: for an obstacle bitmap whose open part lies
  inside the pupil, the bitmap read as area coverage (each pixel a square of its value), whose
  transform is exactly ``s² sinc(θ_x s/λ) sinc(θ_y s/λ)`` times the bitmap's discrete
  transform: its autocorrelation integrated exactly over thirds of a pixel, each third times
  the cells' ``sinc²`` at its centre (the bitmap split into cells of 0.01 mm or less, so that
  the discrete transform's period covers the kernel). For a square it is within 0.01 % of
  the square's exact transform (``--check``).
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.fft

from glarelab.glare import WaveOpticsGlare
from glarelab.glare.models import apertures as ap
from glarelab.glare.models import wave
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
TRIGONAL = {**NONE, "cross_screen": "trigonal"}
FOUR_POINT = {**NONE, "cross_screen": "4-point"}
OTHER_CASES = {
    "round 4.6 mm, lid": dict(pupil_mm=4.6, **LID),
    "round 5 mm, lid": dict(pupil_mm=5.0, **LID),
    "round 6 mm, lid": dict(pupil_mm=6.0, **LID),
    "round 8 mm, lid": dict(pupil_mm=8.0, **LID),
    "round 8 mm, lid, source 10° right": dict(pupil_mm=8.0, source_x_deg=10.0, **LID),
    "round 3 mm, 4-point cross screen": dict(pupil_mm=3.0, **FOUR_POINT),
    "round 8 mm, 4-point cross screen": dict(pupil_mm=8.0, **FOUR_POINT),
    "round 2 mm, trigonal cross screen": dict(pupil_mm=2.0, **TRIGONAL),
    "round 3 mm, trigonal cross screen": dict(pupil_mm=3.0, **TRIGONAL),
    "round 8 mm, trigonal cross screen": dict(pupil_mm=8.0, **TRIGONAL),
    "triangle 3 mm at 0°, trigonal cross screen": dict(
        pupil_mm=3.0, diaphragm_sides=3, **TRIGONAL
    ),
    "square 2 mm at 45°, trigonal cross screen": dict(
        pupil_mm=2.0, diaphragm_sides=4, diaphragm_rotation_deg=45.0, **TRIGONAL
    ),
    "hexagon 4 mm at 0°, trigonal cross screen": dict(
        pupil_mm=4.0, diaphragm_sides=6, **TRIGONAL
    ),
}  # fmt: skip
# (pupil mm, bitmap, its pixel mm, diaphragm sides): the bitmap's open part inside the pupil
# (reference "bitmap") or cut by it ("rim": reference "fine")
IMAGE_CASES = {
    f"image {kind}, {spacing:g} mm pixels, round {pupil:g} mm": (pupil, kind, spacing)
    for pupil, kind, spacing in [
        (3.6, "bars", 0.004), (3.6, "bars", 0.01), (3.6, "bars", 0.025), (3.6, "bars", 0.04),
        (3.6, "square", 0.01), (3.6, "square", 0.025), (3.6, "grey disc", 0.01),
        (3.0, "rim", 0.01), (3.0, "rim", 0.025),
    ]
}  # fmt: skip


def masks() -> dict[str, np.ndarray]:
    y, x = np.indices(SHAPE) - SHAPE[0] // 2
    radius = np.hypot(x, y) * PIXEL_DEG
    border = np.zeros(SHAPE, bool)
    border[[0, -1], :] = border[:, [0, -1]] = True
    return {"ring 0.2-0.3°": (radius >= 0.2) & (radius < 0.3), "border": border}


def one_sample_kernels(model: WaveOpticsGlare) -> np.ndarray:
    """The model's kernels with every edge drawn by the one-sample cover (the model before)."""
    return prefilter_kernels(model, ap.PREFILTER_BOX)


def unlocked_grid(model: WaveOpticsGlare) -> ap.ApertureGrid:
    """The grid the kernel asks for, without an obstacle image's or a polygon's phase lock
    (a round pupil's: the diaphragm does not bind the spacing)."""
    saved = wave.IMAGE_PHASE_REFINEMENT
    wave.IMAGE_PHASE_REFINEMENT = 0.0
    try:
        return replace(model, diaphragm_sides=None).grid_for(PIXEL_DEG, SHAPE)
    finally:
        wave.IMAGE_PHASE_REFINEMENT = saved


def prefilter_kernels(
    model: WaveOpticsGlare, prefilter: tuple[int, int], aperture: np.ndarray | None = None
) -> np.ndarray:
    """The model's kernels with the whole aperture (or ``aperture``, on the grid the kernel
    asks for) drawn under ``prefilter``, whose transfer is divided out at each pixel's
    centre."""
    grid = unlocked_grid(model)
    t = model._aperture_crop(grid, prefilter) if aperture is None else aperture
    acf = aperture_autocorrelation(t, grid.spacing_mm)
    reach = model._extent_deg(PIXEL_DEG, SHAPE)
    return np.array([
        pixel_integrated_psf(acf, float(w), PIXEL_DEG, SHAPE, reach_deg=reach,
                             edge_transfer=True, prefilter=prefilter)
        for w in model._wavelengths()
    ])  # fmt: skip


def interpolated_kernels(model: WaveOpticsGlare) -> np.ndarray:
    """The model before for an obstacle image: the other obstacles by the one-sample cover
    times the bitmap linearly interpolated onto the grid (open beyond it)."""
    from scipy.ndimage import map_coordinates

    grid = unlocked_grid(model)
    plain = replace(model, obstacle_image=None, obstacle_spacing_mm=None)
    t = plain._aperture_crop(grid)
    x, y = ap.ApertureGrid(t.shape[0], grid.spacing_mm).coordinates()
    image, spacing = model.obstacle_image, model.obstacle_spacing_mm
    rows, cols = image.shape[0] // 2 - y / spacing, image.shape[1] // 2 + x / spacing
    t = t * np.clip(map_coordinates(image, [rows, cols], order=1, mode="constant", cval=1.0),
                    0.0, 1.0)  # fmt: skip
    return prefilter_kernels(model, ap.PREFILTER_BOX, t)


def bitmap_kernels(image: np.ndarray, spacing_mm: float, wavelengths_nm, *, thirds: int = 3):
    """The exact pattern of a bitmap read as area coverage (its open part inside the pupil)."""
    split = math.ceil(spacing_mm / 0.01 - 1e-9)
    image = np.kron(image, np.ones((split, split)))  # the same squares, cut into split²
    spacing = spacing_mm / split
    acf = aperture_autocorrelation(image, spacing)
    sub = PIXEL_DEG / thirds
    side = SHAPE[0] * thirds
    angle = (np.arange(side) - side // 2) * math.radians(sub)
    kernels = []
    for w in wavelengths_nm:
        k = pixel_integrated_psf(acf, float(w), sub, (side, side))
        cells = np.sinc(angle * spacing / (float(w) * 1e-6)) ** 2
        k = k * cells[:, None] * cells[None, :]
        kernels.append(k.reshape(SHAPE[0], thirds, SHAPE[1], thirds).sum(axis=(1, 3)))
    return np.array(kernels)


def bitmap(spacing_mm: float, kind: str, *, half_mm: float = 2.0) -> np.ndarray:
    """Test bitmaps centred on the axis, ``2 half_mm`` wide: ``square``, an open square of
    about 2 mm; ``bars``, the square crossed by an opaque bar 0.05 mm wide each way;
    ``grey disc``, a disc of 2.4 mm, its rim its exact cover of each pixel (greys), with an
    opaque bar 0.06 mm wide at 30°; ``rim``, bars 0.05 mm wide 0.3 mm apart, open beyond the
    bitmap, which the pupil cuts."""
    n = 2 * round(half_mm / spacing_mm) + 1
    axis = (np.arange(n) - n // 2) * spacing_mm
    x, y = np.meshgrid(axis, -axis)
    square = ((np.abs(x) <= 1.0 + 1e-9) & (np.abs(y) <= 1.0 + 1e-9)).astype(float)
    if kind == "square":
        return square
    if kind == "bars":
        square[np.abs(x - 0.3) <= 0.025 + 1e-9] = 0.0
        square[np.abs(y + 0.2) <= 0.025 + 1e-9] = 0.0
        return square
    if kind == "grey disc":
        k = 16  # each pixel's cover of the disc from 16² points
        offsets = (np.arange(k) + 0.5) / k - 0.5
        inside = np.zeros_like(x)
        for dy in offsets:
            for dx in offsets:
                px, py = x + dx * spacing_mm, y + dy * spacing_mm
                bar = np.abs(-px * math.sin(math.pi / 6) + py * math.cos(math.pi / 6)) <= 0.03
                inside += (np.hypot(px, py) <= 1.2) & ~bar
        return inside / k**2
    if kind == "rim":
        lines = np.abs((x + 0.15) % 0.3 - 0.15) <= 0.025 + 1e-9
        return np.where(lines | (np.abs(y - 0.4) <= 0.025 + 1e-9), 0.0, 1.0)
    raise ValueError(f"kind must be square, bars, grey disc or rim; got {kind!r}")


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
    """The fine reference against the triangle's exact transform, and the bitmap reference
    against a square's."""
    from tests.glare.models.test_wave_exact import polygon_pixels

    for spacing in (0.01, 0.025):
        image = bitmap(spacing, "square")
        side = float(image[image.shape[0] // 2].sum()) * spacing
        reference = bitmap_kernels(image, spacing, (380.0, 780.0))
        everywhere = np.logical_or(*masks().values())
        for i, w in enumerate((380.0, 780.0)):
            exact = polygon_pixels(4, side * math.sqrt(2), 45.0, w, PIXEL_DEG, 15, everywhere)
            for name, mask in masks().items():
                print(f"bitmap {spacing:g} mm, {w:g} nm {name}: "
                      f"{reference[i][mask].sum() / exact[mask].sum() - 1:+.5f}")  # fmt: skip

    model = WaveOpticsGlare(pupil_mm=3.0, diaphragm_sides=3, **NONE,
                            spectrum=TWO_WAVELENGTHS)  # fmt: skip
    reference = fine_exact_kernels(model)
    regions = masks()
    everywhere = np.logical_or(*regions.values())
    for i, w in enumerate(model._wavelengths()):
        exact = polygon_pixels(3, 3.0, 0.0, w, PIXEL_DEG, 15, everywhere)
        for name, mask in regions.items():
            print(f"{w:g} nm {name}: {reference[i][mask].sum() / exact[mask].sum() - 1:+.5f}")


def sweep() -> None:
    """A square diaphragm at 45° of side 2.000-2.050 mm, 380 nm, against its transform."""
    from tests.glare.models.test_wave_exact import polygon_pixels

    regions = masks()
    everywhere = np.logical_or(*regions.values())
    required = 380e-6 / (wave.PSF_PERIOD_KERNELS * math.radians(SHAPE[0] * PIXEL_DEG))
    variants = [((5, 3), 1, False), ((5, 3), 5, False), ((5, 4), 5, False), ((7, 4), 1, False),
                ((7, 4), 5, False), ((5, 3), 1, True), ((5, 3), 5, True),
                ((5, 3), 1, "model")]  # fmt: skip
    worst: dict[tuple, float] = {}
    # and the edges exactly on a sample and exactly half-way between two (86 and 86.5 samples
    # from the axis), where every copy adds in phase
    sides = [*np.round(np.arange(2.000, 2.0501, 0.005), 3), 2 * 86.0 * required,
             2 * 86.5 * required]  # fmt: skip
    for side in sides:
        diameter = float(side) * math.sqrt(2.0)
        reference = polygon_pixels(4, diameter, 45.0, 380.0, PIXEL_DEG, 15, everywhere)
        line = [f"{side:.5f} mm"]
        for prefilter, parts, quarter in variants:
            spacing = required
            if quarter == "model":  # the model's grid (WaveOpticsGlare._diaphragm_phase_spacing)
                spacing = WaveOpticsGlare(
                    pupil_mm=diameter, diaphragm_sides=4, diaphragm_rotation_deg=45.0, **NONE,
                    spectrum=TWO_WAVELENGTHS,
                ).grid_for(PIXEL_DEG, SHAPE).spacing_mm  # fmt: skip
            elif quarter:  # the edges, side/2 from the axis, at a quarter of a sample
                spacing = side / 2 / (math.ceil(side / 2 / required - 0.25) + 0.25)
            n = 2 * (math.ceil(diameter / 2 / spacing) + 2) + 1
            t = ap.aperture_diaphragm(ap.ApertureGrid(n, spacing), diameter, 4,
                                      rotation_deg=45.0, prefilter=prefilter)  # fmt: skip
            acf = aperture_autocorrelation(t, spacing)
            k = pixel_integrated_psf(acf, 380.0, PIXEL_DEG, SHAPE, reach_deg=SHAPE[0] * PIXEL_DEG,
                                     edge_transfer=True, prefilter=prefilter,
                                     transfer_parts=parts)  # fmt: skip
            errors = [k[mask].sum() / reference[mask].sum() - 1 for mask in regions.values()]
            key = (prefilter, parts, quarter)
            worst[key] = max(worst.get(key, 0.0), *map(abs, errors))
            line.append(f"{prefilter}/{parts}{' ' + str(quarter) if quarter else ''}: "
                        f"ring {errors[0]:+.4f} border {errors[1]:+.4f}")  # fmt: skip
        print(" | ".join(line), flush=True)
    for (prefilter, parts, quarter), value in worst.items():
        print(f"worst {prefilter}, transfer over {parts} part(s)"
              f"{', the model grid' if quarter == 'model' else ''}"
              f"{', quarter-sample grid' if quarter is True else ''}: {value:.4f}")  # fmt: skip


def others(out: Path) -> None:
    """``others_prefilter.csv``: the lid, cross screens and obstacle images before and now."""
    from glarelab.glare.models.wave import DIAPHRAGM_PREFILTER, TRIGONAL_PREFILTER

    rows = []
    cases = {name: (parameters, None) for name, parameters in OTHER_CASES.items()}
    for name, (pupil, kind, spacing) in IMAGE_CASES.items():
        image = bitmap(spacing, kind)
        cases[name] = (
            dict(pupil_mm=pupil, obstacle_image=image, obstacle_spacing_mm=spacing, **NONE),
            None if kind == "rim" else (image, spacing),
        )
    for case, (parameters, exact) in cases.items():
        model = WaveOpticsGlare(**parameters, spectrum=TWO_WAVELENGTHS)
        one_sample, one_sample_s = timed(one_sample_kernels, model)
        prefiltered, prefilter_s = prefilter_kernels(model, DIAPHRAGM_PREFILTER), None
        if model.obstacle_image is not None:
            prefiltered, prefilter_s = timed(prefilter_kernels, model, DIAPHRAGM_PREFILTER)
        trigonal = prefilter_kernels(model, TRIGONAL_PREFILTER)
        interpolated, interpolated_s = (None, None)
        if model.obstacle_image is not None:
            interpolated, interpolated_s = timed(interpolated_kernels, model)
        (now, nm), now_s = timed(model.monochromatic_kernels, PIXEL_DEG, SHAPE)
        uses = {ap.PREFILTER_BOX: "one_sample", DIAPHRAGM_PREFILTER: "prefilter",
                TRIGONAL_PREFILTER: "trigonal_prefilter"}[model._prefilter()]  # fmt: skip
        if exact is None:
            reference, source = fine_exact_kernels(model), "fine"
        else:
            reference, source = bitmap_kernels(*exact, nm), "bitmap"

        def ratio(kernels, i, mask, ref):
            return "" if kernels is None else f"{kernels[i][mask].sum() / ref - 1:+.4f}"

        before_s = one_sample_s if interpolated_s is None else interpolated_s
        for i, w in enumerate(nm):
            for name, mask in masks().items():
                ref = reference[i][mask].sum()
                rows.append(
                    {"case": case, "wavelength_nm": f"{w:g}", "region": name,
                     "one_sample": ratio(one_sample, i, mask, ref),
                     "interpolated": ratio(interpolated, i, mask, ref),
                     "prefilter": ratio(prefiltered, i, mask, ref),
                     "trigonal_prefilter": ratio(trigonal, i, mask, ref),
                     "model": ratio(now, i, mask, ref), "model_uses": uses,
                     "reference": source, "before_s": f"{before_s:.3f}",
                     "prefilter_s": "" if prefilter_s is None else f"{prefilter_s:.3f}",
                     "model_s": f"{now_s:.3f}"}
                )  # fmt: skip
                print(rows[-1], flush=True)
    with open(out / "others_prefilter.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs/optics"))
    parser.add_argument("--check", action="store_true", help="only check the reference")
    parser.add_argument("--no-fft", action="store_true", help="leave out the 8192² FFT check")
    parser.add_argument("--others", action="store_true", help="write others_prefilter.csv")
    parser.add_argument("--sweep", action="store_true", help="a square's edge over the grid")
    parser.add_argument(
        "--only", nargs="+", metavar="CASE",
        help="rerun these cases of combined_prefilter.csv, keep the other rows (and, with "
        "--no-fft, their reference_check, which does not depend on the model)",
    )  # fmt: skip
    args = parser.parse_args()
    if args.check:
        check()
        return
    if args.sweep:
        sweep()
        return
    args.out.mkdir(parents=True, exist_ok=True)
    if args.others:
        others(args.out)
        return
    rows = []
    kept = {}
    if args.only:
        unknown = sorted(set(args.only) - set(CASES))
        if unknown:
            raise SystemExit(f"--only: unknown cases {unknown}; allowed: {list(CASES)}")
        with open(args.out / "combined_prefilter.csv", newline="") as f:
            kept = {(r["case"], r["wavelength_nm"], r["region"]): r for r in csv.DictReader(f)}
    for case, parameters in CASES.items():
        if args.only and case not in args.only:
            rows.extend(r for key, r in kept.items() if key[0] == case)
            continue
        model = WaveOpticsGlare(**parameters, spectrum=TWO_WAVELENGTHS)
        before, before_s = timed(one_sample_kernels, model)
        (now, nm), now_s = timed(model.monochromatic_kernels, PIXEL_DEG, SHAPE)
        reference = fine_exact_kernels(model)
        other = None if args.no_fft else fine_kernels(model)
        for i, w in enumerate(nm):
            for name, mask in masks().items():
                ref = reference[i][mask].sum()
                check_ = "" if other is None else f"{other[i][mask].sum() / ref - 1:+.4f}"
                if other is None and kept:
                    check_ = kept[(case, f"{w:g}", name)]["reference_check"]
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
