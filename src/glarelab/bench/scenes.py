"""The scenes of the benchmark, which glare's own tests render too: one builder per kind of
scene, :data:`WORKLOADS` by name, the models benched on each (:data:`MODELS`) and the display
their errors are counted on (:data:`CALIBRATION`).

Every builder returns ``(luminance in cd/m², pixel_deg)`` and is reproducible from its seed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from glarelab import glare

__all__ = [
    "CALIBRATION",
    "LARGE",
    "L_DMAX",
    "MODELS",
    "WORKLOADS",
    "bench_model",
    "glints_scene",
    "lamps_scene",
    "leaves_scene",
    "night_scene",
    "sun_scene",
    "workload",
    "workload_names",
    "yoshida_scene",
]

CALIBRATION = (
    Path(__file__).resolve().parents[3] / "calibrations" / "SYNTHETIC-yoshida2008-433cd-10bit.json"
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


def _rng(seed: int) -> np.random.Generator:
    """The texture's generator; a seed that is not an integer >= 0 is refused (ValueError)."""
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0 (a random seed), got {seed!r}")
    return np.random.default_rng(seed)


def sun_scene(n: int, *, seed: int = 0) -> tuple[np.ndarray, float]:
    """A 7.5e8 cd/m² sun disk (Spencer Fig. 16) over a landscape the display can show.

    Sky 60-180 cd/m² brightening towards the sun, ground 10-40 cd/m² below a horizon at
    two thirds of the height; the sun at a third of the height. Every pixel but the sun is
    displayable, so the whole image is a target and the dark ground lies next to the sun.

    Parameters
    ----------
    n
        The image's side, pixels; the scene spans :data:`LARGE_FOV_DEG` degrees.
    seed
        The seed of its texture; default 0.

    Returns
    -------
    image : numpy.ndarray
        ``(H, W)`` luminance, cd/m².
    pixel_deg : float
        Visual angle of one pixel, degrees.
    """
    rng = _rng(seed)
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

    Parameters
    ----------
    n
        The image's side, pixels; the scene spans :data:`LARGE_FOV_DEG` degrees.
    seed
        The seed of its texture; default 0.

    Returns
    -------
    image : numpy.ndarray
        ``(H, W)`` luminance, cd/m².
    pixel_deg : float
        Visual angle of one pixel, degrees.
    """
    rng = _rng(seed)
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
    """Sunlit water: 20 cd/m² waves with 0.1 % glints of 1e3-1e6 cd/m² all over the image.

    Parameters
    ----------
    n
        The image's side, pixels; the scene spans :data:`LARGE_FOV_DEG` degrees.
    seed
        The seed of its texture; default 0.

    Returns
    -------
    image : numpy.ndarray
        ``(H, W)`` luminance, cd/m².
    pixel_deg : float
        Visual angle of one pixel, degrees.
    """
    rng = _rng(seed)
    image = np.exp(np.log(20.0) + 0.3 * rng.standard_normal((n, n)))
    glints = rng.random((n, n)) < 0.001
    image[glints] = 10 ** rng.uniform(3, 6, int(glints.sum()))
    return image, LARGE_FOV_DEG / n


def yoshida_scene(*, seed: int = 0) -> tuple[np.ndarray, float]:
    """The Yoshida 2008 stimulus: 271² at 0.011824°/px, a 0.3° disk at 7000 cd/m² (level
    F) on a 150 ± 15 cd/m² sky.

    Parameters
    ----------
    seed
        The seed of its texture; default 0.

    Returns
    -------
    image : numpy.ndarray
        ``(H, W)`` luminance, cd/m².
    pixel_deg : float
        Visual angle of one pixel, degrees.
    """
    rng = _rng(seed)
    n, pixel = 271, 0.011824  # 3.2° at the paper's display geometry
    y, x = np.indices((n, n)) - n // 2
    disk = np.hypot(x, y) * pixel <= 0.15
    sky = np.clip(150 + 15 * rng.standard_normal((n, n)), 0, 200)
    return np.where(disk, 7000.0, sky), pixel


def night_scene(*, seed: int = 0) -> tuple[np.ndarray, float]:
    """Spencer Fig. 14 style: 1280 × 1024 at 0.03°/px, 0.05 cd/m² road, six headlights.

    Parameters
    ----------
    seed
        The seed of its texture; default 0.

    Returns
    -------
    image : numpy.ndarray
        ``(H, W)`` luminance, cd/m².
    pixel_deg : float
        Visual angle of one pixel, degrees.
    """
    rng = _rng(seed)
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
    In RGB the background is bluish and each lamp sodium orange or white.

    Parameters
    ----------
    shape
        ``(H, W)``, pixels.
    lamps
        The number of lamps.
    pixel_deg
        Visual angle of one pixel, degrees (returned as given).
    colour
        Whether the image is RGB ``(H, W, 3)``; default False.
    glint_cd_m2
        The glint's luminance, cd/m²; default None: no glint.
    seed
        The seed of its texture; default 0.

    Returns
    -------
    image : numpy.ndarray
        ``(H, W)`` or ``(H, W, 3)`` luminance, cd/m².
    pixel_deg : float
        ``pixel_deg``.
    """
    rng = _rng(seed)
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
CITY_PIXEL_DEG = 0.04  # the 1024² city and street: 41° across
WORKLOADS = {  # name → builder: the scenes of the benchmark and of the tests
    "yoshida2008": yoshida_scene,
    "night_1280x1024": night_scene,
    "city_1024": lambda: lamps_scene((1024, 1024), 2000, pixel_deg=CITY_PIXEL_DEG),
    "street_rgb_1024": lambda: lamps_scene(
        (1024, 1024), 200, pixel_deg=CITY_PIXEL_DEG, colour=True
    ),
    "sun_1024": lambda: sun_scene(1024),
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


def workload(name: str) -> tuple[np.ndarray, float]:
    """One workload: (luminance image, pixel_deg).

    Parameters
    ----------
    name
        A key of :data:`WORKLOADS`.

    Returns
    -------
    image : numpy.ndarray
        ``(H, W)`` luminance, cd/m².
    pixel_deg : float
        Visual angle of one pixel, degrees.

    Raises
    ------
    ValueError
        For an unknown name.
    """
    if name not in WORKLOADS:
        raise ValueError(f"unknown workload {name!r}; choose from {sorted(WORKLOADS)}")
    return WORKLOADS[name]()


def workload_names(large: bool = False) -> list[str]:
    """The workloads run by default, and with ``large`` the 4096² ones too.

    Parameters
    ----------
    large
        Whether to include the 4096² scenes (:data:`LARGE`); default False.

    Returns
    -------
    list of str
        Names of :data:`WORKLOADS`, in its order.
    """
    return [name for name in WORKLOADS if large or name not in LARGE]


# workload → the models benched on it
MODELS = {
    "yoshida2008": ("vos", "gaussian"),
    "night_1280x1024": ("vos_scotopic",),
    "city_1024": ("vos",),
    "street_rgb_1024": ("vos",),
    "sun_1024": ("vos",),
    "street_256": ("vos",),
    "strip_4096x256": ("vos",),
    "sun_2048": ("vos",),
    "leaves_2048": ("vos",),
    "glints_2048": ("vos", "gaussian"),
    "city_2048": ("vos", "vos_mesopic"),
    "city_rgb_2048": ("vos",),
    "night_sun_2048": ("vos",),
    "sun_4096": ("vos",),
    "leaves_4096": ("vos",),
    "glints_4096": ("vos", "gaussian"),
}


def bench_model(name: str, pixel: float):
    """The glare model a workload is benched with, by name.

    Parameters
    ----------
    name
        ``'vos'``, ``'vos_scotopic'`` or ``'gaussian'`` (:data:`MODELS`).
    pixel
        The workload's pixel, degrees: Yoshida's Gaussian is integrated over pixels when
        its σ spans fewer than 3 of them.

    Returns
    -------
    glarelab.glare.GlareModel
        The model.

    Raises
    ------
    ValueError
        For an unknown name.
    """
    if name == "vos":
        return glare.VosGlare()
    if name == "vos_scotopic":
        return glare.VosGlare(regime="scotopic")
    if name == "vos_mesopic":
        return glare.VosGlare(regime="mesopic")
    if name == "gaussian":
        # Yoshida's σ; integrated over pixels when it spans fewer than 3
        sampling = "pixel" if glare.models.SIGMA_DEG_YOSHIDA2008 / pixel < 3 else "point"
        return glare.GaussianGlare(sampling=sampling)
    raise ValueError(f"unknown bench model {name!r}")
