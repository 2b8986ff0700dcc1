"""``glarelab bench``: what each speed knob costs in accuracy, in display codes.

For each workload and model a float64 reference is rendered with generous settings (the exact
render: full-reach kernel, full resolution, and for the Vos PSF 4× the default integration
samples). Every variant is timed in this process, the contenders interleaved (one run of each
in turn, ``repeats`` rounds, the best kept), with the kernel digitised beforehand for every
one of them (a stimulus set renders many images with one kernel): our renderers are built
and run once before timing, the peers get the digitised kernel. One row, ``add_glare, one
call``, pays the digitisation. Errors are in codes of the shipped 10-bit, 433 cd/m²
synthetic display (continuous codes through its calibration: 0.5 is half a step).

Peers, timed in the same run: ``irfft2(rfft2(ΔL) · K̂)`` with the kernel's spectrum computed
once (the best a user could write with ``scipy.fft``; float64, and float32 where it stays
within half a code); ``scipy.signal.fftconvolve`` of the whole excess image with the full
kernel; for the Gaussian ``scipy.ndimage.gaussian_filter`` and OpenCV's ``GaussianBlur``
(when ``cv2`` is installed), each truncated at 4-6 σ.

Workloads (:data:`WORKLOADS`): the Yoshida 2008 stimulus at the paper's display geometry; a
1280 × 1024 night scene with six headlights (Spencer Fig. 14); a 256² street with a few
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
import math
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import scipy.fft
from scipy.signal import fftconvolve

from glarelab import glare
from glarelab.glare.models.digitise import kernel_shape_for
from glarelab.glare.rendering._convolve import FFT_WORKERS
from glarelab.glare.rendering.display import display_codes
from glarelab.protocols.atomic import atomic_open, write_bytes, write_text
from glarelab.stimuli.calibration import Calibration

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


def lamps_scene(
    shape: tuple[int, int],
    lamps: int,
    *,
    pixel_deg: float,
    colour: bool = False,
    glint_cd_m2: float | None = None,
    seed: int = 0,
) -> tuple[np.ndarray, float]:
    """A night street: 0.01-1 cd/m² (log-uniform texture), ``lamps`` lamps of 3 × 3 px at
    1e3-1e5 cd/m² anywhere, and optionally a 2 × 2 glint (a sun reflected in a window).
    In RGB the background is bluish and each lamp sodium orange or white."""
    rng = np.random.default_rng(seed)
    height, width = shape
    image = 10 ** rng.uniform(-2, 0, shape)
    if colour:
        image = image[..., None] * np.array([0.8, 0.9, 1.2])
    for _ in range(lamps):
        row, col = rng.integers(0, height - 2), rng.integers(0, width - 2)
        level = 10 ** rng.uniform(3, 5)
        tint = (np.array([1.0, 0.55, 0.15]) if rng.random() < 0.5 else 1.0) if colour else 1.0
        image[row : row + 3, col : col + 3] = level * tint
    if glint_cd_m2 is not None:
        row, col = int(0.3 * height), int(0.6 * width)
        image[row : row + 2, col : col + 2] = glint_cd_m2
    return image, pixel_deg


NIGHT_PIXEL_DEG = 0.02  # the 2048² night scenes: 41° across
WORKLOADS = {  # name → builder: the scenes of the benchmark and of the tests
    "yoshida2008": yoshida_scene,
    "night_1280x1024": night_scene,
    "street_256": lambda: lamps_scene((256, 256), 6, pixel_deg=0.05),
    "strip_4096x256": lambda: lamps_scene((256, 4096), 24, pixel_deg=NIGHT_PIXEL_DEG),
    "sun_2048": lambda: sun_scene(2048),
    "leaves_2048": lambda: leaves_scene(2048),
    "glints_2048": lambda: glints_scene(2048),
    "city_2048": lambda: lamps_scene((2048, 2048), 300, pixel_deg=NIGHT_PIXEL_DEG),
    "city_rgb_2048": lambda: lamps_scene(
        (2048, 2048), 300, pixel_deg=NIGHT_PIXEL_DEG, colour=True
    ),
    "night_sun_2048": lambda: lamps_scene(
        (2048, 2048), 3, pixel_deg=NIGHT_PIXEL_DEG, glint_cd_m2=SUN_CD_M2
    ),
    "sun_4096": lambda: sun_scene(4096),
    "leaves_4096": lambda: leaves_scene(4096),
    "glints_4096": lambda: glints_scene(4096),
}
LARGE = ("sun_4096", "leaves_4096", "glints_4096")
MEMORY_WORKLOADS = ("leaves_2048", "night_sun_2048")  # peak memory, in separate processes


def workload(name: str) -> tuple[np.ndarray, float]:
    """One workload: (luminance image, pixel_deg)."""
    if name not in WORKLOADS:
        raise ValueError(f"unknown workload {name!r}; choose from {sorted(WORKLOADS)}")
    return WORKLOADS[name]()


def workload_names(large: bool = False) -> list[str]:
    """The workloads run by default, and with ``large`` the 4096² ones too."""
    return [name for name in WORKLOADS if large or name not in LARGE]


def _spectrum_peer(image, kernel, dtype) -> Callable[[], np.ndarray]:
    """The peer a user could write: the kernel's spectrum computed once, then per image
    ``irfft2(rfft2(ΔL padded to next_fast_len) · K̂)``, every channel at once."""
    height, width = image.shape[:2]
    lengths = tuple(scipy.fft.next_fast_len(2 * n - 1, real=True) for n in (height, width))
    placed = np.zeros(lengths + kernel.shape[2:], dtype=dtype)
    placed[: 2 * height - 1, : 2 * width - 1] = kernel
    placed = np.roll(placed, (1 - height, 1 - width), axis=(0, 1))
    with scipy.fft.set_workers(FFT_WORKERS):
        spectrum = scipy.fft.rfft2(placed, axes=(0, 1))
    if image.ndim == 3 and kernel.ndim == 2:
        spectrum = spectrum[..., None]
    work = image.astype(dtype)

    def peer():
        with scipy.fft.set_workers(FFT_WORKERS):
            excess = np.maximum(work - dtype(L_DMAX), dtype(0))
            transformed = scipy.fft.rfft2(excess, s=lengths, axes=(0, 1)) * spectrum
            spread = scipy.fft.irfft2(transformed, s=lengths, axes=(0, 1))[:height, :width]
        return np.minimum(work + spread, dtype(L_DMAX))

    return peer


def _fftconvolve_peer(image, kernel) -> Callable[[], np.ndarray]:
    """``scipy.signal.fftconvolve`` of the whole excess image with the full kernel."""

    def peer():
        excess = np.maximum(image - L_DMAX, 0.0)
        with scipy.fft.set_workers(FFT_WORKERS):
            if image.ndim == 3:
                k = kernel if kernel.ndim == 3 else kernel[..., None]
                spread = fftconvolve(excess, k, mode="same", axes=(0, 1))
            else:
                spread = fftconvolve(excess, kernel, mode="same")
        return np.minimum(image + spread, L_DMAX)

    return peer


def _timed(variants: dict[str, Callable[[], np.ndarray]], repeats: int) -> dict:
    """Best time and last result of each variant, the variants run in turn ``repeats``
    times (so that a busy moment of a shared machine does not fall on one of them)."""
    times = {name: [] for name in variants}
    results = {}
    for _ in range(repeats):
        for name, function in variants.items():
            start = time.perf_counter()
            results[name] = function()
            times[name].append(time.perf_counter() - start)
    return {name: (min(times[name]), results[name]) for name in variants}


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
            **options,
        )
        self.image = image
        self()

    def __call__(self) -> np.ndarray:
        result = self.renderer.render(self.image)
        self.path = result.plan.path + (" (fallback)" if result.fallback else "")
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
    variants[PEER_SPECTRUM] = _spectrum_peer(image, values, np.float64)
    variants[PEER_SPECTRUM_32] = _spectrum_peer(image, values, np.float32)
    variants[PEER] = _fftconvolve_peer(image, values)
    if isinstance(model, glare.GaussianGlare):
        variants.update(_gaussian_peers(image, pixel, model))
    return variants


def _gaussian_peers(image, pixel, model) -> dict[str, Callable[[], np.ndarray]]:
    from scipy.ndimage import gaussian_filter

    sigma_px = model.sigma_deg / pixel

    def excess():
        return np.maximum(image - L_DMAX, 0.0)

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
    peers = {}
    for truncate in GAUSSIAN_PEER_TRUNCATE:
        peers[f"peer: scipy gaussian_filter ({truncate:g} σ)"] = scipy_filter(truncate)
        if cv2 is not None:
            peers[f"peer: OpenCV GaussianBlur ({truncate:g} σ)"] = opencv_blur(truncate)
    return peers


DEFAULT = "default (renderer, plan, 0.5 codes)"
PEER = "peer: scipy fftconvolve, whole image, full kernel"
PEER_SPECTRUM = "peer: rfft2 with precomputed kernel spectrum, float64"
PEER_SPECTRUM_32 = "peer: rfft2 with precomputed kernel spectrum, float32"
GAUSSIAN_PEER_TRUNCATE = (4.0, 5.0, 6.0)  # 4 σ is both libraries' default
DIRECT_LIMIT = 2e9  # multiply-adds up to which the direct path alone is timed
# workload → the models benched on it
MODELS = {
    "yoshida2008": ("vos", "gaussian"),
    "night_1280x1024": ("vos_scotopic",),
    "street_256": ("vos",),
    "strip_4096x256": ("vos",),
    "sun_2048": ("vos",),
    "leaves_2048": ("vos",),
    "glints_2048": ("vos", "gaussian"),
    "city_2048": ("vos",),
    "city_rgb_2048": ("vos",),
    "night_sun_2048": ("vos",),
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


FRESH_WORKLOADS = ("night_sun_2048",)  # the one-call workload, timed in fresh processes
FRESH_EMPTY = "add_glare, one call, fresh process, empty kernel cache"
FRESH_WARM = "add_glare, one call, fresh process, warm kernel cache"
_FRESH_CALL = """
import sys, time
import numpy as np
from glarelab import glare
from glarelab.bench import CALIBRATION, L_DMAX, _model, workload
from glarelab.stimuli.calibration import Calibration

name, model_name, out = sys.argv[1:4]
image, pixel = workload(name)
model = _model(model_name, pixel)
lut = Calibration.load(CALIBRATION).lut
start = time.perf_counter()
result = glare.add_glare(image, model, pixel_deg=pixel, l_dmax_cd_m2=L_DMAX, display=lut)
seconds = time.perf_counter() - start
np.save(out, result)
print(repr(seconds))
"""


def _fresh_call(
    name: str, model_name: str, cache_dir: Path, out: Path
) -> tuple[float, np.ndarray]:
    """One ``add_glare`` in a new Python process whose kernel cache is ``cache_dir``: the
    seconds of the call alone (the process's start-up is timed by :func:`startup_bench`)."""
    import os
    import subprocess
    import sys

    root = str(Path(__file__).resolve().parents[1])
    path = os.environ.get("PYTHONPATH")
    env = {**os.environ, "GLARELAB_CACHE": str(cache_dir), "PYTHONPATH": root}
    env.pop("GLARELAB_NO_CACHE", None)
    if path:
        env["PYTHONPATH"] = os.pathsep.join([root, path])
    done = subprocess.run(
        [sys.executable, "-c", _FRESH_CALL, name, model_name, str(out)],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise RuntimeError(f"the fresh-process call failed:\n{done.stderr}")
    return float(done.stdout.strip().splitlines()[-1]), np.load(out)


def fresh_bench(name: str, model_name: str, repeats: int, log=print) -> dict:
    """The one-call workload: ``add_glare`` in a fresh process with an empty kernel cache
    (a new folder each time) and with a warm one (filled by an earlier process); the best
    of ``repeats`` each, and the last image of each."""
    import tempfile

    results = {}
    with tempfile.TemporaryDirectory(prefix="glarelab-bench-") as folder:
        folder = Path(folder)
        empty = []
        for index in range(repeats):
            seconds, image = _fresh_call(
                name, model_name, folder / f"empty{index}", folder / "out.npy"
            )
            empty.append(seconds)
            log(f"  fresh process, empty cache: {seconds:.3f} s")
        results[FRESH_EMPTY] = (min(empty), image)
        warm = []
        for _ in range(repeats):
            seconds, image = _fresh_call(name, model_name, folder / "empty0", folder / "out.npy")
            warm.append(seconds)
            log(f"  fresh process, warm cache: {seconds:.3f} s")
        results[FRESH_WARM] = (min(warm), image)
    return results


STARTUP_BASELINE = "import numpy, scipy.fft"
STARTUP_CASES = {  # label → Python code, or None for the console command
    STARTUP_BASELINE: "import numpy, scipy.fft",
    "from glarelab import glare": "from glarelab import glare",
    "glarelab --version": None,
}


def _import_seconds(code: str) -> float:
    """Seconds of the imports in ``code`` in a new interpreter (``python -X importtime``:
    the sum of the top-level imports' cumulative times)."""
    import subprocess
    import sys

    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env=_source_env(),
    )
    total = 0
    for line in done.stderr.splitlines():
        if not line.startswith("import time:") or "|" not in line:
            continue
        fields = line.split("|")
        if fields[-1].startswith(" ") and not fields[-1].startswith("  "):  # top level
            try:
                total += int(fields[1])
            except ValueError:  # the header line
                continue
    return total * 1e-6


def _source_env() -> dict:
    import os

    root = str(Path(__file__).resolve().parents[1])
    path = os.environ.get("PYTHONPATH")
    return {**os.environ, "PYTHONPATH": os.pathsep.join([root, path]) if path else root}


def _wall_seconds(arguments: list[str]) -> float:
    import subprocess
    import sys

    start = time.perf_counter()
    subprocess.run(
        [sys.executable, *arguments], capture_output=True, check=True, env=_source_env()
    )
    return time.perf_counter() - start


def startup_bench(repeats: int = 5, log=print) -> list[dict]:
    """Start-up: the imports of ``import numpy, scipy.fft``, ``from glarelab import glare`` and
    ``glarelab --version`` (``python -X importtime``), and each process's wall time; the
    median of ``repeats`` runs, the cases in turn, with each case's ratio to numpy and
    scipy.fft (the median of the per-round ratios)."""
    rounds = []
    for _ in range(repeats):
        measured = {}
        for label, code in STARTUP_CASES.items():
            if code is None:
                imports = _import_seconds("from glarelab.cli import main")
                wall = _wall_seconds(["-m", "glarelab", "--version"])
            else:
                imports = _import_seconds(code)
                wall = _wall_seconds(["-c", code])
            measured[label] = (imports, wall)
        rounds.append(measured)
    rows = []
    for label in STARTUP_CASES:
        imports = [r[label][0] for r in rounds]
        walls = [r[label][1] for r in rounds]
        ratios = [r[label][0] / r[STARTUP_BASELINE][0] for r in rounds]
        wall_ratios = [r[label][1] / r[STARTUP_BASELINE][1] for r in rounds]
        rows.append(
            {
                "case": label,
                "import_s": float(np.median(imports)),
                "process_s": float(np.median(walls)),
                "import_ratio": float(np.median(ratios)),
                "process_ratio": float(np.median(wall_ratios)),
            }
        )
        log(
            f"  {label}: imports {rows[-1]['import_s']:.3f} s ({rows[-1]['import_ratio']:.2f}×), "
            f"process {rows[-1]['process_s']:.3f} s ({rows[-1]['process_ratio']:.2f}×)"
        )
    return rows


def memory_bench(name: str, log=print) -> list[dict]:
    """Peak memory (MiB) of one Vos render of a workload, allocated through Python and NumPy
    (``tracemalloc``; FFT scratch inside pocketfft is not counted) on top of the image and the
    digitised kernel: ours (renderer built with the kernel, then one render) and the two FFT
    peers (their kernel spectrum included)."""
    import tracemalloc

    image, pixel = workload(name)
    model = glare.VosGlare()
    kernel = model.kernel(pixel, kernel_shape_for(image.shape))
    contenders = {
        DEFAULT: lambda: glare.GlareRenderer(
            model, pixel_deg=pixel, shape=image.shape, kernel=kernel
        ).render(image),
        PEER_SPECTRUM: lambda: _spectrum_peer(image, kernel.values, np.float64)(),
        PEER: lambda: _fftconvolve_peer(image, kernel.values)(),
    }
    rows = []
    for label, contender in contenders.items():
        tracemalloc.start()
        try:
            contender()
            mib = tracemalloc.get_traced_memory()[1] / 2**20
        finally:
            tracemalloc.stop()
        rows.append({"workload": name, "variant": label, "peak_mib": mib})
        log(f"  memory, {label}: {mib:.0f} MiB")
    return rows


def spectral_bench(
    shape: tuple[int, int] = (1025, 1025), *, pixel_deg: float = 0.004, repeats: int = 1
) -> list[dict]:
    """Wave-optics PSF (6 mm eye, lashes, lid, particles) as an RGB kernel: one FFT per
    wavelength (the reference, 61 wavelengths) against exactly rescaled copies of one FFT,
    Kakimoto's three wavelengths, and fewer wavelengths; time and CIEDE2000 against the
    reference (:func:`glarelab.glare.models.wave.kernel_colour_error`). The kernels are FFT samples
    rebinned (``pixel_integration='rebin'``), the path whose cost these methods differ in: with
    exact pixel integration one autocorrelation serves every wavelength
    (docs/speed-accuracy.md)."""

    def kernel(**options):
        model = glare.WaveOpticsGlare(pupil_mm=6.0, pixel_integration="rebin", **options)
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
    for label, (seconds, rgb) in _timed(variants, repeats).items():
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
            model = _model(model_name, pixel)
            label = f"[{number}/{len(names)}] {name} / {model_name}"
            log(f"{label}: {image.shape[1]} × {image.shape[0]} px at {pixel:.4g}°/px")
            reference_codes = display_codes(_reference(image, pixel, model), lut)
            kernel = model.kernel(pixel, kernel_shape_for(image.shape), colour=image.ndim == 3)
            variants = _variants(image, pixel, model, lut, kernel)
            results = []
            timed = _timed(variants, repeats)
            if fresh and name in FRESH_WORKLOADS:
                timed |= fresh_bench(name, model_name, repeats, log=log)
            for variant, (seconds, result) in timed.items():
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
                    }
                )
                log(f"  {variant}: {seconds:.3f} s, max error {error.max():.3g} codes")
            by_variant = {r["variant"]: r["seconds"] for r in results}
            for r in results:
                r["speed_vs_peer"] = by_variant[PEER] / r["seconds"]
                r["speed_vs_spectrum_peer"] = by_variant[PEER_SPECTRUM] / r["seconds"]
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


def _best_peer(mine: list[dict], bound: float) -> dict | None:
    """The fastest peer whose error is within ``bound`` codes."""
    peers = [
        r for r in mine if r["variant"].startswith("peer") and float(r["max_error_codes"]) <= bound
    ]
    return min(peers, key=lambda r: float(r["seconds"]), default=None)


def tables(
    rows: list[dict],
    spectral_rows: list[dict] = (),
    memory_rows: list[dict] = (),
    startup_rows: list[dict] = (),
) -> str:
    """Markdown: a summary per workload and model (the default against the exact render and
    the peers, as ratios of times measured in the same run), then every variant, then peak
    memory and the spectral section."""
    lines = [
        "| workload | model | default (s) | path | error (codes) | fastest peer within "
        "0.5 codes | peer (s) | × faster than it | × faster than rfft2 with precomputed "
        "spectrum | × faster than full-kernel fftconvolve |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for key in dict.fromkeys((r["workload"], r["model"]) for r in rows):
        mine = [r for r in rows if (r["workload"], r["model"]) == key]
        default = next(r for r in mine if r["variant"] == DEFAULT)
        best = _best_peer(mine, 0.5)
        spectrum = next(r for r in mine if r["variant"] == PEER_SPECTRUM)
        full = next(r for r in mine if r["variant"] == PEER)
        lines.append(
            f"| {key[0]} | {key[1]} | {float(default['seconds']):.3f} | "
            f"{default.get('path', '')} | {float(default['max_error_codes']):.2g} | "
            f"{best['variant'].removeprefix('peer: ')} | {float(best['seconds']):.3f} | "
            f"{float(best['seconds']) / float(default['seconds']):.2f} | "
            f"{float(spectrum['seconds']) / float(default['seconds']):.2f} | "
            f"{float(full['seconds']) / float(default['seconds']):.2f} |"
        )
    lines += [
        "",
        "| workload | model | variant | time (s) | × rfft2-spectrum peer | × fftconvolve peer "
        "| max error (codes) | RMS (codes) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    lines += [
        f"| {r['workload']} | {r['model']} | {r['variant']} | {float(r['seconds']):.3f} | "
        f"{float(r['speed_vs_spectrum_peer']):.2f} | {float(r['speed_vs_peer']):.2f} | "
        f"{float(r['max_error_codes']):.3g} | {float(r['rms_error_codes']):.3g} |"
        for r in rows
    ]
    if startup_rows:
        lines += [
            "",
            "| start-up | imports (s) | × import numpy, scipy.fft | process (s) | × its process |",
            "| --- | --- | --- | --- | --- |",
        ]
        lines += [
            f"| {r['case']} | {float(r['import_s']):.3f} | {float(r['import_ratio']):.2f} | "
            f"{float(r['process_s']):.3f} | {float(r['process_ratio']):.2f} |"
            for r in startup_rows
        ]
    if memory_rows:
        lines += ["", "| workload | variant | peak memory (MiB) |", "| --- | --- | --- |"]
        lines += [
            f"| {r['workload']} | {r['variant']} | {float(r['peak_mib']):.0f} |"
            for r in memory_rows
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

    from glarelab.analysis.figures import plt, png

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
            edgecolors="k" if r["variant"] == DEFAULT else "none",
        )
    axis.axhline(0.5, color="k", ls="--", lw=0.8, label="half a display code")
    axis.set(
        xscale="log",
        yscale="log",
        xlabel="time (s, best of the rounds, kernel digitised beforehand)",
        ylabel=f"max error (10-bit codes; < {floor:g} at {floor:g})",
        title=title,
    )
    axis.xaxis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    axis.xaxis.set_minor_formatter(NullFormatter())  # minor labels collide on short spans
    axis.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.02, 0.5), frameon=False)
    write_bytes(path, png(figure))
