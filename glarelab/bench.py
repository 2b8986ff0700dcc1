"""``glarelab bench``: what each speed knob costs in accuracy, in display codes.

For each workload and model a float64 reference is rendered with generous settings (the exact
render: full-reach kernel, full resolution, and for the Vos PSF 4× the default integration
samples). Every variant is timed (median of repeats, in this process, kernel digitisation
included: what a user pays) and compared with the reference in the codes of the shipped
10-bit, 433 cd/m² synthetic display (continuous codes through its calibration: 0.5 is half a
step). Peers are timed in the same run and every time is also a ratio to them:
``scipy.signal.fftconvolve`` of the whole excess image with the full kernel (the kernel
digitised as ours is), and for the Gaussian ``scipy.ndimage.gaussian_filter`` and OpenCV's
``GaussianBlur`` (when ``cv2`` is installed), each truncated at 4 σ, their defaults.

Workloads (:func:`workloads`): the Yoshida 2008 stimulus at the paper's display geometry; a
1280 × 1024 night scene with six headlights (Spencer Fig. 14); 2048² scenes at 40° with a
7.5e8 cd/m² sun disk over a displayable landscape, the Fig. 16 tree against a 4000 cd/m² sky
with the sun through three holes, and water with glints (many bright pixels all over);
``large`` adds the 4096² versions. The spectral section times the wave-optics PSF's
``scaled`` copies against one FFT per wavelength, with CIEDE2000.
"""

from __future__ import annotations

import csv
import math
import statistics
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.fft
from scipy.signal import fftconvolve

import glare
from glare._convolve import FFT_WORKERS, bounding_box, spread
from glare.digitise import kernel_shape_for
from glare.display import display_codes
from stimuli.calibration import Calibration

__all__ = ["WORKLOADS", "run_bench", "spectral_bench", "workload", "workload_names"]

CALIBRATION = (
    Path(__file__).resolve().parents[1] / "calibrations" / "SYNTHETIC-yoshida2008-433cd-10bit.json"
)
L_DMAX = 220.0


SUN_CD_M2 = 7.5e8  # Spencer 1995 Fig. 16: the sun disk
SKY_CD_M2 = 4.0e3  # Spencer 1995 Fig. 16: the sky behind the tree
SUN_RADIUS_DEG = 0.265  # the sun's angular radius (0.53° across)
LARGE_FOV_DEG = 40.0  # field of view of the 2048² and 4096² scenes


def _one_over_f(shape: tuple[int, int], rng: np.random.Generator, scale_px: float) -> np.ndarray:
    """Zero-mean, unit-variance noise with a 1/f amplitude spectrum between scale/8 and
    scale/4 cycles per pixel... i.e. features from about scale/4 to 8 scale pixels."""
    spectrum = rng.standard_normal(shape) + 1j * rng.standard_normal(shape)
    f = np.hypot(np.fft.fftfreq(shape[0])[:, None], np.fft.fftfreq(shape[1])[None, :])
    amplitude = np.where(
        (f >= 1 / (8 * scale_px)) & (f <= 4 / scale_px), 1 / np.maximum(f, 1e-9), 0
    )
    field = np.fft.ifft2(spectrum * amplitude).real
    return (field - field.mean()) / field.std()


def sun_scene(n: int, *, seed: int = 0) -> tuple[np.ndarray, float]:
    """A 7.5e8 cd/m² sun disk (Spencer Fig. 16) over a landscape the display can show.

    Sky 60-180 cd/m² brightening towards the sun, ground 10-40 cd/m² below a horizon at
    two thirds of the height; the sun at a third of the height. Every pixel but the sun is
    displayable, so the whole image is a target and the dark ground lies next to the sun.
    """
    rng = np.random.default_rng(seed)
    pixel = LARGE_FOV_DEG / n
    yy, xx = np.indices((n, n))
    cy, cx = n // 3, int(0.55 * n)
    distance_deg = np.hypot(yy - cy, xx - cx) * pixel
    sky = 60.0 + 120.0 * np.exp(-distance_deg / 15.0)
    ground = np.exp(np.log(20.0) + 0.35 * _one_over_f((n, n), rng, n / 128))
    image = np.where(yy < 2 * n // 3, sky, np.clip(ground, 10.0, 40.0))
    image[distance_deg <= SUN_RADIUS_DEG] = SUN_CD_M2
    return image, pixel


def leaves_scene(n: int, *, seed: int = 0) -> tuple[np.ndarray, float]:
    """Spencer Fig. 16: a tree against a 4000 cd/m² sky, the sun through three holes.

    Leaves 5-200 cd/m² (log-normal), sky in the canopy's gaps (about 12 % of the pixels,
    all above L_dmax: many bright pixels all over the image), and the 7.5e8 cd/m² sun
    covered by leaves except for three small holes.
    """
    rng = np.random.default_rng(seed)
    pixel = LARGE_FOV_DEG / n
    gaps = _one_over_f((n, n), rng, n / 64) > 1.2
    leaves = np.clip(np.exp(np.log(60.0) + 0.5 * _one_over_f((n, n), rng, n / 256)), 5, 200)
    image = np.where(gaps, SKY_CD_M2, leaves)
    yy, xx = np.indices((n, n))
    cy, cx = int(0.35 * n), int(0.6 * n)
    radius_px = SUN_RADIUS_DEG / pixel
    sun = np.hypot(yy - cy, xx - cx) <= radius_px
    image[sun] = leaves[sun]
    hole_px = max(1.5, 0.06 / pixel)
    for dy, dx in ((-0.4, 0.1), (0.2, -0.3), (0.1, 0.45)):
        hole = np.hypot(yy - cy - dy * radius_px, xx - cx - dx * radius_px) <= hole_px
        image[hole & sun] = SUN_CD_M2
    return image, pixel


def glints_scene(n: int, *, seed: int = 0) -> tuple[np.ndarray, float]:
    """Sunlit water: 20 cd/m² waves with 0.1 % glints of 1e3-1e6 cd/m² all over the image."""
    rng = np.random.default_rng(seed)
    image = np.exp(np.log(20.0) + 0.3 * rng.standard_normal((n, n)))
    glints = rng.random((n, n)) < 0.001
    image[glints] = 10 ** rng.uniform(3, 6, int(glints.sum()))
    return image, LARGE_FOV_DEG / n


def yoshida_scene(*, seed: int = 0) -> tuple[np.ndarray, float]:
    """The Yoshida 2008 stimulus: 271² at 0.011824°/px, a 0.3° disk at 7000 cd/m² (level
    F) on a 150 ± 15 cd/m² sky."""
    rng = np.random.default_rng(seed)
    n, pixel = 271, 0.011824  # 3.2° at the paper's display geometry
    y, x = np.indices((n, n)) - n // 2
    disk = np.hypot(x, y) * pixel <= 0.15
    sky = np.clip(150 + 15 * rng.standard_normal((n, n)), 0, 200)
    return np.where(disk, 7000.0, sky), pixel


def night_scene(*, seed: int = 0) -> tuple[np.ndarray, float]:
    """Spencer Fig. 14 style: 1280 × 1024 at 0.03°/px, 0.05 cd/m² road, six headlights."""
    rng = np.random.default_rng(seed)
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
    return night, 0.03


WORKLOADS = {  # name → builder: the scenes of the benchmark and of the tests
    "yoshida2008": yoshida_scene,
    "night_1280x1024": night_scene,
    "sun_2048": lambda: sun_scene(2048),
    "leaves_2048": lambda: leaves_scene(2048),
    "glints_2048": lambda: glints_scene(2048),
    "sun_4096": lambda: sun_scene(4096),
    "leaves_4096": lambda: leaves_scene(4096),
    "glints_4096": lambda: glints_scene(4096),
}
LARGE = ("sun_4096", "leaves_4096", "glints_4096")


def workload(name: str) -> tuple[np.ndarray, float]:
    """One workload: (luminance image, pixel_deg)."""
    if name not in WORKLOADS:
        raise ValueError(f"unknown workload {name!r}; choose from {sorted(WORKLOADS)}")
    return WORKLOADS[name]()


def workload_names(large: bool = False) -> list[str]:
    """The workloads run by default, and with ``large`` the 4096² ones too."""
    return [name for name in WORKLOADS if large or name not in LARGE]


def _full_kernel_peer(image: np.ndarray, pixel: float, model) -> Callable[[], np.ndarray]:
    """The peer: ``fftconvolve`` of the whole excess image with the full kernel, digitised as
    ours is, on as many FFT threads as ours."""
    full = kernel_shape_for(image.shape)

    def peer():
        kernel = model.kernel(pixel, full).values
        excess = np.maximum(image - L_DMAX, 0.0)
        with scipy.fft.set_workers(FFT_WORKERS):
            spread = fftconvolve(excess, kernel, mode="same")
        return np.minimum(image + spread, L_DMAX)

    return peer


def _timed(function: Callable[[], np.ndarray], repeats: int) -> tuple[float, np.ndarray]:
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def _reach_shape(reach_deg: float, pixel: float, full: tuple[int, int]) -> tuple[int, int]:
    return tuple(min(2 * round(reach_deg / pixel / 2) + 1, f) for f in full)


def _vos_variants(image, pixel, model, lut) -> dict[str, Callable[[], np.ndarray]]:
    full = kernel_shape_for(image.shape)

    def add(chosen=model, **options):
        return lambda: glare.add_glare(
            image, chosen, pixel_deg=pixel, l_dmax_cd_m2=L_DMAX, display=lut, **options
        )

    variants = {
        "default (plan, 0.5 codes)": add(),
        "plan, 2 codes": add(tolerance_codes=2.0),
        "plan, 0.1 codes": add(tolerance_codes=0.1),
        "float32": add(precision="float32"),
        "samples 2/10": add(replace(model, samples_per_pixel=2, center_samples_per_pixel=10)),
        "samples 5/50": add(replace(model, samples_per_pixel=5, center_samples_per_pixel=50)),
        "exact (full kernel, full resolution)": add(tolerance_codes=None),
    }
    for reach in (1.0, 4.0):
        shape = _reach_shape(reach, pixel, full)
        if shape != full:
            variants[f"fixed reach {reach:g}°"] = add(kernel_shape=shape)

    bright = image > L_DMAX
    box = bounding_box(bright)
    box_area = (box[0].stop - box[0].start) * (box[1].stop - box[1].start)
    if box_area * full[0] * full[1] <= DIRECT_LIMIT:

        def direct():
            kernel = model.kernel(pixel, full).values
            excess = np.maximum(image - L_DMAX, 0.0)
            return np.minimum(image + spread(excess, kernel, box, method="direct"), L_DMAX)

        variants["direct convolution over the bright box, full kernel"] = direct
    variants[PEER] = _full_kernel_peer(image, pixel, model)
    return variants


def _gaussian_variants(image, pixel, model, lut) -> dict[str, Callable[[], np.ndarray]]:
    from scipy.ndimage import gaussian_filter

    sigma_px = model.sigma_deg / pixel

    def add(**options):
        return lambda: glare.add_glare(
            image, model, pixel_deg=pixel, l_dmax_cd_m2=L_DMAX, display=lut, **options
        )

    def excess():
        return np.maximum(image - L_DMAX, 0.0)

    variants = {
        "default (plan, 0.5 codes)": add(),
        "plan, 2 codes": add(tolerance_codes=2.0),
        "float32": add(precision="float32"),
        "exact (full kernel, full resolution)": add(tolerance_codes=None),
    }

    def scipy_filter(truncate):
        return lambda: np.minimum(
            image + gaussian_filter(excess(), sigma_px, mode="constant", truncate=truncate),
            L_DMAX,
        )

    def opencv_blur(truncate):
        size = 2 * math.ceil(truncate * sigma_px) + 1
        return lambda: np.minimum(
            image
            + cv2.GaussianBlur(excess(), (size, size), sigma_px, borderType=cv2.BORDER_CONSTANT),
            L_DMAX,
        )

    try:
        import cv2
    except ImportError:  # OpenCV is not a dependency; measured where it is installed
        cv2 = None
    for truncate in GAUSSIAN_PEER_TRUNCATE:
        variants[f"peer: scipy gaussian_filter ({truncate:g} σ)"] = scipy_filter(truncate)
        if cv2 is not None:
            variants[f"peer: OpenCV GaussianBlur ({truncate:g} σ)"] = opencv_blur(truncate)

    variants[PEER] = _full_kernel_peer(image, pixel, model)
    return variants


PEER = "peer: scipy fftconvolve, whole image, full kernel"
GAUSSIAN_PEER_TRUNCATE = (4.0, 5.0, 6.0)  # 4 σ is both libraries' default
DIRECT_LIMIT = 2e9  # multiply-adds up to which the direct convolution is timed
# workload → the models benched on it
MODELS = {
    "yoshida2008": ("vos", "gaussian"),
    "night_1280x1024": ("vos_scotopic",),
    "sun_2048": ("vos",),
    "leaves_2048": ("vos",),
    "glints_2048": ("vos", "gaussian"),
    "sun_4096": ("vos",),
    "leaves_4096": ("vos",),
    "glints_4096": ("vos", "gaussian"),
}


def _model(name: str, pixel: float):
    if name == "vos":
        return glare.VosGlare()
    if name == "vos_scotopic":
        return glare.VosGlare(regime="scotopic")
    if name == "gaussian":
        # Yoshida's σ; integrated over pixels when it spans fewer than 3
        sampling = "pixel" if glare.models.SIGMA_DEG_YOSHIDA2008 / pixel < 3 else "point"
        return glare.GaussianGlare(sampling=sampling)
    raise ValueError(f"unknown bench model {name!r}")


def _reference(image, pixel, model):
    if isinstance(model, glare.VosGlare):
        model = replace(
            model,
            samples_per_pixel=4 * model.samples_per_pixel,
            center_samples_per_pixel=4 * model.center_samples_per_pixel,
            halo_spacing_deg=model.halo_spacing_deg / 4,
        )
    return glare.add_glare(image, model, pixel_deg=pixel, tolerance_codes=None)


def spectral_bench(
    shape: tuple[int, int] = (1025, 1025), *, pixel_deg: float = 0.004, repeats: int = 1
) -> list[dict]:
    """Wave-optics PSF (6 mm eye, lashes, lid, particles) as an RGB kernel: one FFT per
    wavelength (the reference, 61 wavelengths) against exactly rescaled copies of one FFT,
    Kakimoto's three wavelengths, and fewer wavelengths; time and CIEDE2000 against the
    reference (:func:`glare.wave.kernel_colour_error`)."""

    def kernel(**options):
        model = glare.WaveOpticsGlare(pupil_mm=6.0, **options)
        return lambda: model.kernel(pixel_deg, shape, colour=True).values

    variants = {
        "reference: one FFT per wavelength (61)": kernel(spectral="reference"),
        "scaled copies of one FFT (61)": kernel(spectral="scaled"),
        "scaled copies, 31 wavelengths": kernel(
            spectral="scaled", spectrum=glare.Spectrum(n_wavelengths=31)
        ),
        "Kakimoto: three wavelengths": kernel(spectral="kakimoto"),
    }
    results, reference = [], None
    for label, function in variants.items():
        seconds, rgb = _timed(function, repeats)
        reference = rgb if reference is None else reference
        error = glare.wave.kernel_colour_error(reference, rgb, "ITU-R BT.709")
        results.append(
            {"workload": f"wave-optics PSF {shape[0]}²", "variant": label, "seconds": seconds}
            | error
        )
    base = results[0]["seconds"]
    for r in results:
        r["speed_vs_peer"] = base / r["seconds"]
    return results


def run_bench(
    out: str | Path,
    *,
    large: bool = False,
    only: tuple[str, ...] | None = None,
    spectral: bool = True,
    repeats: int = 3,
    log=print,
) -> list[dict]:
    """Run the benchmark; write ``bench.csv``, ``bench.md`` and one Pareto PNG per workload.

    Parameters
    ----------
    out
        Directory for the results.
    large
        Add the 4096² scenes.
    only
        Run only these workloads (names of :func:`workloads`).
    spectral
        Also run :func:`spectral_bench`.
    repeats
        Timings per variant; the median is reported.
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
    for name in names:
        image, pixel = workload(name)
        for model_name in MODELS[name]:
            model = _model(model_name, pixel)
            label = f"{name} / {model_name}"
            log(f"{label}: {image.shape[1]} × {image.shape[0]} px at {pixel:.4g}°/px")
            reference_codes = display_codes(_reference(image, pixel, model), lut)
            variants = (_gaussian_variants if model_name == "gaussian" else _vos_variants)(
                image, pixel, model, lut
            )
            results = []
            for variant, function in variants.items():
                seconds, result = _timed(function, repeats)
                error = np.abs(display_codes(result, lut) - reference_codes)
                results.append(
                    {
                        "workload": name,
                        "model": model_name,
                        "variant": variant,
                        "seconds": seconds,
                        "max_error_codes": float(error.max()),
                        "rms_error_codes": float(np.sqrt(np.mean(error**2))),
                    }
                )
                log(f"  {variant}: {seconds:.3f} s, max error {error.max():.3g} codes")
            peer = next(r["seconds"] for r in results if r["variant"] == PEER)
            for r in results:
                r["speed_vs_peer"] = peer / r["seconds"]
            rows += results
    spectral_rows = []
    if spectral:
        log("wave-optics PSF: scaled copies against one FFT per wavelength")
        spectral_rows = spectral_bench(repeats=1)
        for r in spectral_rows:
            log(f"  {r['variant']}: {r['seconds']:.2f} s, ΔE00 {r['delta_e_mean']:.3g}")
    write_plots(rows, out)
    for name, table in (("bench.csv", rows), ("spectral.csv", spectral_rows)):
        if table:
            with (out / name).open("w", newline="") as handle:
                writer = csv.DictWriter(handle, fieldnames=list(table[0]))
                writer.writeheader()
                writer.writerows(table)
    (out / "bench.md").write_text(tables(rows, spectral_rows))
    return rows + spectral_rows


def _best_peer(mine: list[dict], bound: float) -> dict | None:
    """The fastest peer whose error is within ``bound`` codes (the fftconvolve one is exact)."""
    peers = [r for r in mine if r["variant"].startswith("peer") and r["max_error_codes"] <= bound]
    return min(peers, key=lambda r: r["seconds"], default=None)


def tables(rows: list[dict], spectral_rows: list[dict] = ()) -> str:
    """Markdown: a summary per workload and model (the default against the exact render and
    the fastest peer within half a code), then every variant, then the spectral section."""
    lines = [
        "| workload | model | default (s) | error (codes) | exact (s) | fastest peer within "
        "0.5 codes | peer (s) | × faster than it | × faster than full-kernel fftconvolve |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for key in dict.fromkeys((r["workload"], r["model"]) for r in rows):
        mine = [r for r in rows if (r["workload"], r["model"]) == key]
        default = next(r for r in mine if r["variant"].startswith("default"))
        exact = next(r for r in mine if r["variant"].startswith("exact"))
        full = next(r for r in mine if r["variant"] == PEER)
        best = _best_peer(mine, 0.5)
        lines.append(
            f"| {key[0]} | {key[1]} | {default['seconds']:.3f} | "
            f"{default['max_error_codes']:.2g} | {exact['seconds']:.3f} | "
            f"{best['variant'].removeprefix('peer: ')} | {best['seconds']:.3f} | "
            f"{best['seconds'] / default['seconds']:.2f} | "
            f"{full['seconds'] / default['seconds']:.2f} |"
        )
    lines += [
        "",
        "| workload | model | variant | time (s) | × peer speed | max error (codes) "
        "| RMS (codes) |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    lines += [
        f"| {r['workload']} | {r['model']} | {r['variant']} | {float(r['seconds']):.3f} | "
        f"{float(r['speed_vs_peer']):.2f} | {float(r['max_error_codes']):.3g} | "
        f"{float(r['rms_error_codes']):.3g} |"
        for r in rows
    ]
    if spectral_rows:
        lines += [
            "",
            "| PSF | variant | time (s) | × reference speed | mean ΔE00 | max ΔE00 "
            "| luminance error |",
            "| --- | --- | --- | --- | --- | --- | --- |",
        ]
        lines += [
            f"| {r['workload']} | {r['variant']} | {float(r['seconds']):.2f} | "
            f"{float(r['speed_vs_peer']):.2f} | {float(r['delta_e_mean']):.3g} | "
            f"{float(r['delta_e_max']):.3g} | {float(r['luminance_error']):.2g} |"
            for r in spectral_rows
        ]
    return "\n".join(lines) + "\n"


def write_plots(rows: list[dict], out: Path) -> None:
    """One Pareto PNG per workload and model, ``pareto_<workload>_<model>.png``."""
    for key in dict.fromkeys((r["workload"], r["model"]) for r in rows):
        results = [r for r in rows if (r["workload"], r["model"]) == key]
        title = f"{key[0]} / {key[1]}: time against error"
        _pareto(results, title, Path(out) / f"pareto_{key[0]}_{key[1]}.png")


def _pareto(results: list[dict], title: str, path: Path) -> None:
    """Time against largest error, one marker per variant (legend at the side), log-log;
    peers are squares, the plan's points are joined (its tolerance is the knob)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    from analysis.figures import plt, png

    floor = 1e-4  # errors below this are drawn on it (a log axis has no zero)
    markers = "oD^v<>phX*P"  # squares are for peers
    figure, axis = plt.subplots(figsize=(8.5, 4.2))
    plan = [r for r in results if r["variant"].startswith(("default", "plan"))]
    plan.sort(key=lambda r: r["seconds"])
    axis.plot(
        [r["seconds"] for r in plan],
        [max(r["max_error_codes"], floor) for r in plan],
        color="0.7",
        lw=1,
        zorder=1,
    )
    for index, r in enumerate(results):
        peer = r["variant"].startswith("peer")
        axis.scatter(
            r["seconds"],
            max(r["max_error_codes"], floor),
            s=42,
            marker="s" if peer else markers[index % len(markers)],
            label=r["variant"].removeprefix("peer: "),
            zorder=2,
            edgecolors="k" if r["variant"].startswith("default") else "none",
        )
    axis.axhline(0.5, color="k", ls="--", lw=0.8, label="half a display code")
    axis.set(
        xscale="log",
        yscale="log",
        xlabel="time (s, median, kernel digitisation included)",
        ylabel=f"max error (10-bit codes; < {floor:g} at {floor:g})",
        title=title,
    )
    axis.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.xaxis.set_minor_formatter(NullFormatter())  # minor labels collide on short spans
    axis.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5), frameon=False)
    path.write_bytes(png(figure))
