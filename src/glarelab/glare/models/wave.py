"""Wave-optics glare: the Fraunhofer diffraction pattern of the obstacles before the retina.

For an aperture of amplitude transmittance ``t(x, y)`` (mm) lit by a plane wave of wavelength
``λ``, the eye focused at infinity forms on the retina (Kakimoto et al. 2004, eqs. 2, 5)

.. math:: I(\\theta_x, \\theta_y) \\propto \\frac{1}{\\lambda^2}
          \\Bigl| \\mathcal{F}[t](\\theta_x / \\lambda, \\theta_y / \\lambda) \\Bigr|^2 ,

a function of angle ``θ = x_f / f``. On a grid of ``N`` samples spaced ``δ`` mm, the DFT gives
``F[t]`` at frequencies ``k / (N δ)``, so the PSF's angular sample spacing is ``λ / (N δ)``
radians and its extent ``λ / δ``. Two conditions keep it honest:

- the grid must be at least twice the aperture (``N δ ≥ 2 D``): the PSF is the transform of
  the aperture's autocorrelation, which is twice as wide; a smaller grid wraps it round;
- the aperture must be resolved (``D / δ`` samples), else its sampled spectrum is aliased.

:func:`psf_fraunhofer` enforces both (padding automatically, refusing what it cannot fix).
The kernel integrates each wavelength's PSF exactly over each stimulus pixel
(:func:`glarelab.glare.models.fraunhofer.pixel_integrated_psf`: the aperture's autocorrelation
through a matrix DFT), with the transfer of the antialiased edges, ``sinc²(θ δ / λ)``, divided
out, so that the kernel is the pattern of the aperture described, not of its samples; the
PSF's period is three kernel widths (:meth:`WaveOpticsGlare.grid_for`). Against the
pixel-integrated Airy pattern, ring energies from 0.3° to 2.5° and the kernel's border are
within 0.6 % for 380-780 nm and 2-8 mm (``tests/glare/models/test_wave_rings.py``). A
diaphragm, alone or behind the lid, a cross screen or an obstacle image, and a round pupil
behind any of these, is drawn with a smoother prefilter (:data:`DIAPHRAGM_PREFILTER`, or
:data:`TRIGONAL_PREFILTER` behind a trigonal screen; the obstacles under it,
:func:`glarelab.glare.models.apertures.aperture_diaphragm_prefiltered`), whose transfer is
divided out instead: a streak along an axis otherwise meets its own copies in the periodic
spectrum, and a 2 mm square at 45° had its border 9.5 % off at 380 nm (+17.6 % for an 8 mm
square behind lid and screen, +4.7 % for a round pupil behind a 4-point screen). An edge along
an axis still meets its copies in a phase constant along it, and the grid's spacing is set so
that it lies a quarter of a sample from the samples, where the nearest copies are in
quadrature (:meth:`WaveOpticsGlare._diaphragm_phase_spacing`; a square's border was +1.06 %
with its edges half-way between two samples, now 0.34 % at worst). Polygons of 3-8 sides are
within 0.31 % of their transform, 0.18 % behind the lid, 0.34 % behind a 4-point screen and
0.3 % behind a trigonal one. An obstacle image is a bitmap read as area
coverage (each pixel a square of its value,
:func:`glarelab.glare.models.apertures.aperture_image_cover`): linearly interpolated onto the
grid, its pattern was up to 65 % off at the border. Its pixels' edges lie along the axes, where
the prefilter's leftover copies add in phase at some edge positions (+1.00 % for a square of
2.025 mm in 0.025 mm pixels): the grid's spacing is made ``2 s / m`` (``m`` odd), which puts
every pixel edge a quarter of a sample from the samples, where the nearest copies are in
quadrature, and the transfer is divided out over fifths of each pixel
(:data:`IMAGE_TRANSFER_PARTS`; +1.06 % for bars cut by the pupil at the pixel's centre): now
within 0.1 %.
``pixel_integration='rebin'`` spreads the DFT's samples over the pixels instead (:func:`rebin`:
exact for the energy, not for the pattern when a pixel spans few samples).

**The Fresnel term** of Luidolt eq. 5.6, ``exp(iπ r² / (λ d))`` with ``d = 24 mm``, is the
quadratic phase of free propagation from the pupil to the retina *without* a lens (after
Ritschel et al. 2009). A focused eye's lens adds ``exp(-iπ r² / (λ f))`` with ``f = d``, which
cancels it exactly; Fraunhofer at the focal plane is then exact (Kakimoto eq. 1 with
``d_o = f``). In physical units the term is large (about 680 half-waves at the edge of a 6 mm
pupil at 550 nm): it spreads the PSF over the pupil's geometric shadow, ``D / d`` radians (14°
for 6 mm). It is available (``fresnel=True``) to reproduce kernels built that way, with
``fresnel_distance_mm`` as its parameter, but is off by default.
``tests/glare/models/test_wave.py`` measures the shadow.

References
----------
Kakimoto, M., Matsuoka, K., Nishita, T., Naemura, T., Harashima, H. (2004). Glare generation
based on wave optics. Pacific Graphics 2004 (12th Pacific Conference on Computer Graphics and
Applications), eqs. 1-7.
Luidolt, L. (2020). Perception of light in virtual reality. TU Wien, §5.2, eqs. 5.5-5.13.
Ritschel, T., Ihrke, M., Frisvad, J. R., et al. (2009). Temporal glare. Eurographics.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Literal

import numpy as np
import scipy.fft
import scipy.sparse

from glarelab.files.values import is_real
from glarelab.glare._colour import colour
from glarelab.glare._validation import (
    check_choice,
    check_flag,
    check_in_range,
    check_pixel_deg,
    check_positive,
    check_positive_int,
)
from glarelab.glare.models import apertures as ap
from glarelab.glare.models.base import GlareModel
from glarelab.glare.models.cache import array_sha256
from glarelab.glare.models.digitise import Kernel, check_kernel_shape
from glarelab.glare.models.eye import pupil_diameter_mm
from glarelab.glare.models.fraunhofer import (
    MAX_GRID,
    MIN_APERTURE_SAMPLES,
    DiffractionPSF,
    _crop_to_reach,
    _fresnel_field,
    _rebin_cropped,
    aperture_autocorrelation,
    pixel_integrated_psf,
    psf_fraunhofer,
    rebin,
)
from glarelab.glare.models.spectral import Spectrum

__all__ = [
    "APERTURE_GRIDS",
    "DIAPHRAGM_PREFILTER",
    "FRESNEL_DISTANCE_MM_LUIDOLT2020",
    "IMAGE_PHASE_REFINEMENT",
    "IMAGE_TRANSFER_PARTS",
    "KAKIMOTO2004_WAVELENGTHS_NM",
    "LUIDOLT2020_PUPIL_RANGE_MM",
    "MAX_EYELASHES",
    "MAX_PARTICLES",
    "MIN_APERTURE_SAMPLES",
    "OBSTACLE_SAMPLES",
    "PIXEL_INTEGRATION_METHODS",
    "PSF_PERIOD_KERNELS",
    "PUPIL_CONVENTIONS",
    "SIGMOID_FORMS",
    "SPECTRAL_METHODS",
    "TRIGONAL_PREFILTER",
    "DiffractionPSF",
    "WaveOpticsGlare",
    "compare_spectral_methods",
    "kernel_colour_error",
    "psf_fraunhofer",
    "rebin",
    "sigmoid_Kakimoto2004",
]

FRESNEL_DISTANCE_MM_LUIDOLT2020 = 24.0  # Luidolt 2020 eq. 5.6: pupil-retina distance d
LUIDOLT2020_REFERENCE_NM = 575.0  # Luidolt 2020 §5.2.2: the one wavelength that is transformed
KAKIMOTO2004_WAVELENGTHS_NM = (680.0, 530.0, 460.0)  # Kakimoto 2004 §3.2: R, G, B
SIGMOID_D_KAKIMOTO2004 = 640.0  # Kakimoto 2004 §3.4: tone curve maximum
SIGMOID_K_KAKIMOTO2004 = 20.0  # Kakimoto 2004 §3.4
SIGMOID_G_KAKIMOTO2004 = 0.465  # Kakimoto 2004 §3.4
PUPIL_SAMPLES = 64  # samples across the pupil the model asks for
PSF_PERIOD_KERNELS = 3.0  # the PSF's period at the shortest wavelength, in kernel widths
PSF_PERIOD_KERNELS_FAST = 2.0  # the same for aperture_grid="fast" (the grid before issue 33)
APERTURE_GRIDS = ("exact", "fast")
OBSTACLE_SAMPLES = 12  # samples across a particle or an eyelash
# Each lash or particle is drawn into the aperture one by one (about 5 ms a lash): a million
# lashes ran for over an hour, a billion particles asked for 7.45 GiB. Particles: 100 times
# Luidolt's 1000 (§5.2.4, Fig. 5.6). Lashes: an upper lid has about 90-160; 1000 lashes of
# 0.09 mm cover the 12 mm lash line (133 side by side) more than seven times, and cost ~5 s.
MAX_PARTICLES = 100_000
MAX_EYELASHES = 1000
# (subsamples, smoothing) of a diaphragm, alone or behind the lid, a 4-point screen or an
# obstacle image, and of a round pupil behind these: its streaks' aliases 0.65 % of them, not
# 9.7 %
DIAPHRAGM_PREFILTER = (5, 3)
# the same behind a trigonal cross screen, whose three line sets cross everywhere and are drawn
# sub-cell by sub-cell there: 25 sub-cells, not 169 (scripts/measure_combined_prefilter.py
# --others: within 0.25 % where the one-sample cover was 0.93 % off, at 1.0-3.6 times its
# time for two wavelengths on 31² at 0.02°/px)
TRIGONAL_PREFILTER = (3, 2)
OBSTACLE_SAMPLES_FAST = 4  # the same for aperture_grid="fast"
# parts of a pixel along each axis over which the prefilter's transfer is divided out for an
# obstacle image: at each pixel's centre, bars cut by a 3 mm pupil (0.01 mm pixels) were
# +1.06 % at the border, their grating's order inside the border pixels; over fifths -0.01 %
# (+0.42 % with the grid's lock of grid_for alone; scripts/measure_combined_prefilter.py
# --others)
IMAGE_TRANSFER_PARTS = 5
# the most an obstacle image's pixel edges may refine the grid to sit a quarter of a sample
# from its samples (grid_for); beyond it the grid is left as the kernel asks
IMAGE_PHASE_REFINEMENT = 3.0
# an aperture passing less of the round pupil's light than this is taken as closed (a kernel of
# no light would render no glare without a word)
LEAST_OPEN_SHARE = 1e-6
# an edge's normal this close to an axis is along it (diaphragm_rotation_deg is given in degrees)
_AXIS_TOLERANCE_DEG = 1e-6
SPECTRAL_METHODS = ("reference", "scaled", "kakimoto")
PIXEL_INTEGRATION_METHODS = ("exact", "rebin")
PUPIL_CONVENTIONS = ("unit-energy", "Luidolt2020")
LUIDOLT2020_PUPIL_RANGE_MM = (2.0, 8.0)  # Luidolt 2020 §5.2.1 ii: "our predefined range of 2–8 mm"
_MM_PER_NM = 1e-6


SIGMOID_FORMS = ("contrast k²", "as printed")


def sigmoid_Kakimoto2004(
    x: np.ndarray,
    *,
    D: float = SIGMOID_D_KAKIMOTO2004,
    k: float = SIGMOID_K_KAKIMOTO2004,
    g: float = SIGMOID_G_KAKIMOTO2004,
    form: Literal["contrast k²", "as printed"] = "contrast k²",
) -> np.ndarray:
    """Kakimoto's sigmoid tone curve for viewing glare images (eqs. 6-7, after Tumblin et al.).

    .. math:: \\mathrm{sig}(x) = \\frac{x^g + 1/k}{x^g + k} D

    Parameters default to the paper's D = 640, k = 20, g = 0.465 (§3.4).

    Parameters
    ----------
    x
        Linear input, >= 0.
    D, k, g
        Maximum, contrast and slope parameters.
    form
        ``'contrast k²'`` (default): the curve above, which has the properties §3.3 gives it:
        "D defines the maximum limit of the output, k² defines the contrast between the
        minimum and the maximum value" (``D/k²`` at 0, ``D`` at infinity, ``D/k`` at
        ``x = 1``, an S symmetric on log-log axes). ``'as printed'``: eq. 7 as printed,
        ``(x^g + 1)/(x^g + k) D``, whose contrast is ``k`` (a floor of 32 on the [0, 255]
        output, a grey where Kakimoto's figures are black): a ``1/k`` lost in print.

    Raises
    ------
    ValueError
        For negative or non-finite ``x`` or an unknown ``form``.

    Examples
    --------
    >>> float(sigmoid_Kakimoto2004(np.array(0.0)))  # D / k²
    1.6
    >>> float(sigmoid_Kakimoto2004(np.array(0.0), form="as printed"))  # D / k
    32.0
    """
    x = np.asarray(x, dtype=float)
    if (x < 0).any() or not np.isfinite(x).all():
        raise ValueError("x must be finite and >= 0")
    power = x**g
    if form == "contrast k²":
        return (power + 1.0 / k) / (power + k) * D
    if form == "as printed":
        return (power + 1.0) / (power + k) * D
    raise ValueError(f"form must be one of {SIGMOID_FORMS}; got {form!r}")


def _luminance_weights(colourspace: str) -> np.ndarray:
    return np.asarray(colour.RGB_COLOURSPACES[colourspace].matrix_RGB_to_XYZ[1])


@dataclass(frozen=True)
class WaveOpticsGlare(GlareModel):
    """Glare as diffraction by the pupil, eyelids, eyelashes, particles and filters.

    Parameters
    ----------
    pupil_mm
        Pupil (or diaphragm) diameter in mm, 1-10; ``None`` (default): from
        ``field_luminance_cd_m2`` by Moon & Spencer
        (:func:`glarelab.glare.models.eye.pupil_diameter_mm`).
    field_luminance_cd_m2
        Adapting luminance for the pupil when ``pupil_mm`` is None; default 1 cd/m² (3.8 mm).
    eyelashes, eyelid
        Include the upper eyelid margin and eyelashes (Kakimoto §3.2); default True.
    eyelash_count, eyelash_thickness_mm, eyelash_curvature
        The procedural lashes (:func:`glarelab.glare.models.apertures.aperture_eyelashes`);
        defaults 45, 0.09 mm, 0.35; at most :data:`MAX_EYELASHES` (1000) lashes.
    particles
        Number of lens/cornea particles (Luidolt §5.2.4 default 1000); 0 for none; at most
        :data:`MAX_PARTICLES` (100000).
    particle_size_mm
        Particle diameter; default 0.042 mm (Luidolt §5.2.4).
    fresnel
        Multiply Luidolt's Fresnel term (eq. 5.6); default False (see the module notes).
    fresnel_distance_mm
        ``d`` of the Fresnel term; default 24 mm (Luidolt).
    spectral
        ``'scaled'`` (default): one FFT, exact scaled copies per wavelength (Luidolt eq. 5.12);
        ``'reference'``: one FFT per wavelength; ``'kakimoto'``: 680/530/460 nm as R/G/B.
        Under ``pixel_integration='exact'`` without ``fresnel`` one autocorrelation of the
        aperture serves every wavelength exactly, so ``'reference'`` would be ``'scaled'``
        and is refused there.
    spectrum
        Wavelength sampling and display for 'scaled' and 'reference'; default 31 wavelengths
        380-780 nm, Rec. 709.
    seed
        Seed of the eyelashes and particles.
    source_x_deg
        Horizontal direction of the light source; moves the eyelashes and lids across the
        pupil by ``obstacle_distance_mm · tan(source_x_deg)`` (Kakimoto §3.2, §4.2).
    obstacle_distance_mm
        Distance of eyelashes and lids in front of the pupil; default 10 mm.
    diaphragm_sides
        A regular polygon of this many sides instead of a round pupil (camera); default None.
    diaphragm_rotation_deg
        Rotation of the polygon, degrees anticlockwise; default 0 (the first edge's normal at
        ``180° / sides``; 45° turns a square's edges onto the axes).
    cross_screen
        ``'4-point'`` or ``'trigonal'`` cross-screen filter; default None.
    eye
        ``'right'`` or ``'left'``: which way the lashes curl.
    psf_extent_deg
        Full width of the PSF computed, degrees; energy beyond it is reported as outside the
        kernel. Default 4.
    obstacle_image, obstacle_spacing_mm
        A user-supplied obstacle transmittance (hand-drawn or photographed, Kakimoto §5), 2-D
        in [0, 1], centred on the optical axis, with its sample spacing in mm; it multiplies
        the other obstacles. It is read as area coverage: each pixel a square of side
        ``obstacle_spacing_mm`` holding its value, open beyond the image
        (:func:`glarelab.glare.models.apertures.aperture_image_cover`), so its pixels' edges
        diffract as drawn; on the exact grid the grid is locked to its pixels (:meth:`grid_for`)
        and the transfer divided out over fifths of each kernel pixel. Default None.
    pixel_integration
        ``'exact'`` (default): each wavelength's PSF integrated exactly over each pixel
        (:func:`glarelab.glare.models.fraunhofer.pixel_integrated_psf`); ``'rebin'``: the PSF
        sampled by an FFT every ``λ / (2.1 D)`` and the samples spread over the pixels, as before
        (the centre pixel of a 3 mm pupil at 0.0118°/px 8 % low; docs/speed-accuracy.md measures
        both).
    aperture_grid
        ``'exact'`` (default): the aperture sampled so that the PSF's period at the shortest
        wavelength is :data:`PSF_PERIOD_KERNELS` (3) kernel widths: ring energies of a round
        pupil within 0.6 % of the Airy pattern's out to the kernel's border. ``'fast'``: two
        kernel widths (2.25 times fewer multiply-adds), particles and lashes resolved
        by :data:`OBSTACLE_SAMPLES_FAST` (4) samples instead of 12, and every aperture drawn
        with the one-sample box instead of the prefilters of polygons, the lid, cross screens
        and images: rings within 1 %, the border within 2-4 % (for a round pupil), and a small
        kernel no longer the large one's centre to 1 % (docs/speed-accuracy.md gives its error
        in display codes).
    pupil_convention
        ``'unit-energy'`` (default): the kernel holds the light that passes the aperture, all
        of the source's excess, whatever the pupil; a larger pupil only narrows the PSF.
        ``'Luidolt2020'``: Luidolt's kernel, whose energy grows with the pupil's area (his
        eq. 5.11 normalises by the grid, not by the aperture; §5.2.4: "A bigger pupil admits
        more light into the eye than a smaller one. Therefore, the resulting glare is more
        intense"): the unit-energy kernel times the open area over the 8 mm disc's
        (:meth:`pupil_share`). Particles are spread at one density over the 8 mm disc in both,
        as Luidolt's fixed particle texture is cut by the pupil. Pupils outside 2-8 mm warn.

    Notes
    -----
    Why unit energy is the default: a pupil twice as wide lets four times the light of the
    source onto the retina, but also four times the light of everything around it, so the
    glare relative to the scene, which is what a display can show, does not grow with the
    pupil's area; the PSF is the distribution of where the light lands, and every other model
    of the suite (Gaussian, Vos) is one. Luidolt's growth with area is how his renderer makes
    glare "more intense at night time"; the option reproduces it.

    Examples
    --------
    >>> m = WaveOpticsGlare(pupil_mm=3.0, eyelashes=False, eyelid=False, particles=0)
    >>> k = m.kernel(0.02, (41, 41))
    >>> k.values.shape, bool(abs(k.values.sum() + k.energy_outside - 1) < 1e-9)
    ((41, 41), True)
    """

    pupil_mm: float | None = None
    field_luminance_cd_m2: float = 1.0
    eyelashes: bool = True
    eyelid: bool = True
    eyelash_count: int = 45
    eyelash_thickness_mm: float = 0.09
    eyelash_curvature: float = 0.35
    particles: int = ap.PARTICLE_COUNT_LUIDOLT2020
    particle_size_mm: float = ap.PARTICLE_SIZE_MM_LUIDOLT2020
    fresnel: bool = False
    fresnel_distance_mm: float = FRESNEL_DISTANCE_MM_LUIDOLT2020
    spectral: Literal["scaled", "reference", "kakimoto"] = "scaled"
    spectrum: Spectrum = field(
        default_factory=lambda: Spectrum(n_wavelengths=31, wavelength_range_nm=(380.0, 780.0))
    )
    seed: int = 0
    source_x_deg: float = 0.0
    obstacle_distance_mm: float = 10.0
    diaphragm_sides: int | None = None
    diaphragm_rotation_deg: float = 0.0
    cross_screen: Literal["4-point", "trigonal"] | None = None
    eye: Literal["left", "right"] = "right"
    psf_extent_deg: float = 4.0
    obstacle_image: np.ndarray | None = field(default=None, compare=False, repr=False)
    obstacle_spacing_mm: float | None = None
    pixel_integration: Literal["exact", "rebin"] = "exact"
    pupil_convention: Literal["unit-energy", "Luidolt2020"] = "unit-energy"
    aperture_grid: Literal["exact", "fast"] = "exact"

    def __eq__(self, other: object) -> bool:
        """Equal fields and the same obstacle image (values, shape and dtype): two models of
        different aperture images compared equal, and a renderer took one's kernel for the
        other's."""
        if other.__class__ is not self.__class__:
            return NotImplemented
        mine = tuple(getattr(self, f.name) for f in fields(self) if f.compare)
        theirs = tuple(getattr(other, f.name) for f in fields(self) if f.compare)
        return mine == theirs and _obstacle_digest(self) == _obstacle_digest(other)

    def description(self, colour: bool) -> dict:
        """The model's name and parameters (:meth:`GlareModel.description`), the obstacle
        image by its digest.

        Parameters
        ----------
        colour
            Whether the kernel described is the colour one.

        Returns
        -------
        dict
            ``model``, the parameters and ``colour``.
        """
        return super().description(colour) | {"obstacle_image": _obstacle_digest(self)}

    def __post_init__(self) -> None:
        for flag in ("eyelashes", "eyelid", "fresnel"):
            check_flag(flag, getattr(self, flag))
        if self.obstacle_image is not None:
            image = ap.aperture_from_image(self.obstacle_image, name="obstacle_image")
            if not np.any(image > 0):
                raise ValueError(
                    "obstacle_image is 0 (opaque) everywhere: no light would reach the retina; "
                    "give transmittances in [0, 1] with some above 0"
                )
            check_positive("obstacle_spacing_mm", self.obstacle_spacing_mm, unit="mm")
        if self.pupil_mm is not None:
            check_in_range("pupil_mm", self.pupil_mm, 1.0, 10.0, unit="mm")
        pupil_diameter_mm(self.field_luminance_cd_m2)  # validates the luminance
        check_positive_int("eyelash_count", self.eyelash_count, minimum=0, maximum=MAX_EYELASHES)
        check_positive("eyelash_thickness_mm", self.eyelash_thickness_mm, unit="mm")
        check_in_range("eyelash_curvature", self.eyelash_curvature, 0.0, 2.0)
        check_positive_int("particles", self.particles, minimum=0, maximum=MAX_PARTICLES)
        check_positive("particle_size_mm", self.particle_size_mm, unit="mm")
        check_positive("fresnel_distance_mm", self.fresnel_distance_mm, unit="mm")
        check_choice("spectral", self.spectral, SPECTRAL_METHODS)
        check_positive_int("seed", self.seed, minimum=0)
        check_in_range("source_x_deg", self.source_x_deg, -60.0, 60.0, unit="deg")
        check_positive("obstacle_distance_mm", self.obstacle_distance_mm, unit="mm")
        if self.diaphragm_sides is not None:
            check_positive_int("diaphragm_sides", self.diaphragm_sides, minimum=3)
        check_in_range("diaphragm_rotation_deg", self.diaphragm_rotation_deg, -360.0, 360.0)
        check_choice("cross_screen", self.cross_screen, (None, "4-point", "trigonal"))
        check_choice("eye", self.eye, ("left", "right"))
        check_positive("psf_extent_deg", self.psf_extent_deg, unit="deg")
        check_choice("pixel_integration", self.pixel_integration, PIXEL_INTEGRATION_METHODS)
        check_choice("pupil_convention", self.pupil_convention, PUPIL_CONVENTIONS)
        check_choice("aperture_grid", self.aperture_grid, APERTURE_GRIDS)
        self._refuse_idle_options()
        if self.pupil_convention == "Luidolt2020":
            low, high = LUIDOLT2020_PUPIL_RANGE_MM
            if not low <= self.pupil_diameter <= high:
                warnings.warn(
                    f"pupil {self.pupil_diameter:g} mm is outside Luidolt's 2-8 mm range; "
                    "pupil_convention='Luidolt2020' scales the kernel by the pupil's area over "
                    "the 8 mm disc's, which exceeds 1 above 8 mm",
                    stacklevel=3,
                )

    def _refuse_idle_options(self) -> None:
        """Refuse an option set away from its default where what it shapes is not drawn (the
        lashes' count without lashes, a rotation without a polygon, ...): the kernel would be
        the default's, and the model's description would claim what it does not do."""
        idle = {
            "eyelashes": ("eyelash_count", "eyelash_thickness_mm", "eyelash_curvature", "eye"),
            "particles": ("particle_size_mm",),
            "fresnel": ("fresnel_distance_mm",),
            "diaphragm_sides": ("diaphragm_rotation_deg",),
            "obstacle_image": ("obstacle_spacing_mm",),
        }
        defaults = {f.name: f.default for f in fields(self)}
        for enabler, options in idle.items():
            value = getattr(self, enabler)
            if value is not None and value is not False and not (is_real(value) and value == 0):
                continue
            for option in options:
                if getattr(self, option) != defaults[option]:
                    raise ValueError(
                        f"{option}={getattr(self, option)!r} has no effect with "
                        f"{enabler}={value!r}: leave {option} at its default "
                        f"({defaults[option]!r}) or set {enabler}"
                    )
        if not (self.eyelashes or self.eyelid):  # the source's angle moves only lashes and lid
            for option in ("source_x_deg", "obstacle_distance_mm"):
                if getattr(self, option) != defaults[option]:
                    raise ValueError(
                        f"{option}={getattr(self, option)!r} has no effect without eyelashes or "
                        f"eyelid (it places them across the pupil): leave it at its default "
                        f"({defaults[option]!r}) or draw them"
                    )
        if self.pupil_mm is not None and (
            self.field_luminance_cd_m2 != defaults["field_luminance_cd_m2"]
        ):
            raise ValueError(
                f"field_luminance_cd_m2={self.field_luminance_cd_m2!r} has no effect with "
                f"pupil_mm={self.pupil_mm!r} (it sets the pupil only when pupil_mm is None): "
                "give one of them"
            )
        if self.spectral == "reference" and self.pixel_integration == "exact" and not self.fresnel:
            raise ValueError(
                "spectral='reference' with pixel_integration='exact' and fresnel=False: each "
                "wavelength's PSF is then integrated from the one autocorrelation of the "
                "aperture, as 'scaled' does, so it would be ignored; give spectral='scaled', "
                "fresnel=True (a Fresnel term per wavelength) or pixel_integration='rebin' "
                "(one FFT per wavelength)"
            )
        if self.seed != defaults["seed"] and not (self.eyelashes or self.particles):
            raise ValueError(
                f"seed={self.seed!r} has no effect without eyelashes or particles (the "
                "only random obstacles): leave it at 0 or draw them"
            )

    # --- aperture -----------------------------------------------------------------------

    @property
    def pupil_diameter(self) -> float:
        """The pupil diameter used, mm."""
        if self.pupil_mm is not None:
            return float(self.pupil_mm)
        return float(pupil_diameter_mm(self.field_luminance_cd_m2))

    def _wavelengths(self) -> np.ndarray:
        if self.spectral == "kakimoto":
            return np.array(KAKIMOTO2004_WAVELENGTHS_NM)
        return self.spectrum.wavelengths_nm

    def _extent_deg(self, pixel_deg: float, shape: tuple[int, int]) -> float:
        # at least one pixel: the PSF's period (twice this) must hold two pixels
        return max(min(max(shape) * pixel_deg, self.psf_extent_deg), pixel_deg)

    def grid_for(self, pixel_deg: float, shape: tuple[int, int]) -> ap.ApertureGrid:
        """The aperture grid that resolves the obstacles and covers the kernel.

        The sample spacing makes the PSF's period at the shortest wavelength at least
        :data:`PSF_PERIOD_KERNELS` (3) times the kernel's width (so the aperture's aliased
        spectrum folds far outside it, and the edges' transfer divided out is at most
        ``sinc²(1/6)`` = 0.91 at the border, 0.83 in the corners), resolves the pupil by 64
        samples and particles and lashes by :data:`OBSTACLE_SAMPLES` (12), and samples the
        Fresnel chirp (if on) below Nyquist; the grid spans twice the pupil. With an obstacle
        image (on the exact grid) the spacing is then made ``2 s / m``, ``m`` the smallest odd
        integer that keeps it no coarser, ``s`` the image's pixel (at most
        :data:`IMAGE_PHASE_REFINEMENT` times finer, and within 8192²): its pixel edges a
        quarter of a sample from the samples (:meth:`_image_phase_spacing`). Without one, a
        polygonal diaphragm with an edge along an axis (not behind a cross screen) makes it
        ``4 a / m``, ``m`` odd, ``a`` its apothem: those edges a quarter of a sample from the
        samples, the spacing at most ``δ / (2 a)`` finer (:meth:`_diaphragm_phase_spacing`).

        With twice the kernel's width and 2 samples across particles and lashes (before issue
        33), the light at 1-2.5° of a round pupil was 22 % low at 380 nm, and the spacing,
        set by the kernel's width, changed the lashes' diffraction with the kernel size.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.

        Returns
        -------
        glarelab.glare.models.apertures.ApertureGrid
            The pupil-plane grid: its size in samples and its spacing, mm.

        Raises
        ------
        ValueError
            If that grid would exceed 8192² samples.
        """
        extent_deg = self._extent_deg(pixel_deg, shape)
        shortest_mm = float(self._wavelengths().min()) * _MM_PER_NM
        diameter = self.pupil_diameter
        if self.aperture_grid == "exact":
            periods = PSF_PERIOD_KERNELS
        elif self.aperture_grid == "fast":
            periods = PSF_PERIOD_KERNELS_FAST
        else:
            raise ValueError(
                f"aperture_grid must be one of {APERTURE_GRIDS}; got {self.aperture_grid!r}"
            )
        limits = {
            f"a PSF period {periods:g} times the {extent_deg:g}° kernel": shortest_mm
            / (periods * math.radians(extent_deg)),
            f"{PUPIL_SAMPLES} samples across the pupil": diameter / PUPIL_SAMPLES,
        }
        across = OBSTACLE_SAMPLES if self.aperture_grid == "exact" else OBSTACLE_SAMPLES_FAST
        if self.particles:
            limits[f"{across} samples across a particle"] = self.particle_size_mm / across
        if self.eyelashes:
            limits[f"{across} samples across an eyelash"] = self.eyelash_thickness_mm / across
        if self.fresnel:  # the chirp at the pupil edge below Nyquist, with 5 % to spare
            limits["the Fresnel term below Nyquist"] = (
                0.95 * shortest_mm * self.fresnel_distance_mm / diameter
            )
        binding = min(limits, key=limits.get)
        spacing = limits[binding]
        n = self._grid_size(spacing)
        locked = self._image_phase_spacing(spacing)
        if locked is None:
            locked = self._diaphragm_phase_spacing(spacing)
        if locked is not None and self._grid_size(locked) <= MAX_GRID:
            spacing, n = locked, self._grid_size(locked)
        if n > MAX_GRID:
            if binding == "the Fresnel term below Nyquist":  # set by the pupil alone
                advice = (
                    f"use a smaller pupil or a fresnel_distance_mm above "
                    f"{self.fresnel_distance_mm:g} (the pixels do not set this grid)"
                )
            else:
                advice = "use a smaller pupil, coarser pixels or a smaller psf_extent_deg"
            raise ValueError(
                f"the aperture grid would need {n}² samples (more than {MAX_GRID}²) for "
                f"{binding} with a {diameter:g} mm pupil; {advice}"
            )
        return ap.ApertureGrid(n, spacing)

    def check_kernel(
        self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False
    ) -> None:
        """Refuse a kernel whose aperture grid would be too large (:meth:`grid_for`).

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether the colour kernel would be made (the grid is the same); default False.

        Raises
        ------
        ValueError
            If that grid would exceed 8192² samples.
        """
        self.grid_for(check_pixel_deg(pixel_deg), check_kernel_shape(shape))

    def _grid_size(self, spacing_mm: float) -> int:
        """Samples per side of a grid of ``spacing_mm`` that spans 2.1 pupils (even)."""
        n = scipy.fft.next_fast_len(math.ceil(2.1 * self.pupil_diameter / spacing_mm))
        return n + n % 2

    def _image_phase_spacing(self, spacing_mm: float) -> float | None:
        """For an obstacle image under a prefilter: the largest spacing ``δ <= spacing_mm`` with
        ``s / δ`` half an odd integer (``s`` the image's pixel), which puts every edge of its
        pixels, at ``(k + 1/2) s`` from the axis, a quarter of a sample from the grid's
        samples; None without an image, on the fast grid, or where that would refine the grid
        by more than :data:`IMAGE_PHASE_REFINEMENT`.

        A straight edge along an axis at ``x₀`` meets its own copies in the sampled
        aperture's periodic spectrum, ``j / δ`` apart along that axis; the streak and its
        copy ``j`` differ in phase by ``2π j x₀ / δ``, which does not vary along the edge, so
        their cross term adds ``2 cos(2π j x₀ / δ)`` times the copy's amplitude to the
        streak's light (the (5, 3) prefilter leaves the copies 0.65 % of it: the border of a
        square bitmap of 2.025 mm was +1.00 % at 380 nm, a square diaphragm of 2.000 to
        2.050 mm between −0.96 % and +1.06 %, the extremes with its edges on a sample or
        half-way between two). A quarter of a sample puts the nearest copies
        (``j = ±1``, and every odd ``j``) in quadrature: their cross term vanishes for every
        edge of the bitmap, whatever its size (the diaphragm swept over those sizes on such a
        grid, the transfer divided over fifths: −0.11 % to −0.09 %;
        ``scripts/measure_combined_prefilter.py --sweep``).
        """
        if self.obstacle_image is None or self._prefilter() == ap.PREFILTER_BOX:
            return None
        pixel_mm = float(self.obstacle_spacing_mm)
        odd = math.ceil(2.0 * pixel_mm / spacing_mm - 1e-9)
        odd += 1 - odd % 2
        locked = 2.0 * pixel_mm / odd
        return locked if spacing_mm / locked <= IMAGE_PHASE_REFINEMENT else None

    def _diaphragm_phase_spacing(self, spacing_mm: float) -> float | None:
        """For a polygonal diaphragm under a prefilter with an edge along an axis: the largest
        spacing ``δ <= spacing_mm`` with ``4 a / δ`` an odd integer (``a`` the apothem, every
        edge's distance from the centre), which puts the axis edges, at ``±a``, a quarter of
        a sample from the samples; None for a round pupil, a polygon without an edge along an
        axis, with an obstacle image (locked to its pixels instead), behind a cross screen
        (whose lines along the axes have phases of their own), or on the fast grid.

        The copies of an axis edge's streak in the sampled aperture's spectrum lie on the
        streak, ``j / δ`` apart, in the phase ``2π j a / δ`` that does not vary along the edge
        (:meth:`_image_phase_spacing`): a square diaphragm at 45°, 380 nm, was +1.06 % at the
        border with its edges half-way between two samples and −0.96 % on them. A quarter of
        a sample puts the odd copies in quadrature (the spacing becomes finer by less than
        ``δ / (2 a)``: 0.4 % for a 2 mm square on 31² at 0.02°/px; at most 3 % where the
        pupil's 64 samples set it, a triangle's apothem a quarter of its diameter). An edge at 45°
        (``x ± y = ±a√2``) has copies on its streak too, at ``(j, j) / δ``, but they are
        ``√2`` times farther and weakened by the prefilter's transfer along both axes, a
        hundredth of an axis edge's; the other angles of 3-8 sides put no copy on the
        streak (``tan θ`` irrational). A polygon whose normals miss the axes keeps its grid.
        """
        if (
            self.diaphragm_sides is None
            or self.obstacle_image is not None
            or self.cross_screen is not None
            or self._prefilter() == ap.PREFILTER_BOX
        ):
            return None
        sides = int(self.diaphragm_sides)
        normals_deg = self.diaphragm_rotation_deg + (np.arange(sides) + 0.5) * 360.0 / sides
        off_axis_deg = np.abs((normals_deg + 45.0) % 90.0 - 45.0)
        if not np.any(off_axis_deg < _AXIS_TOLERANCE_DEG):
            return None
        apothem_mm = self.pupil_diameter / 2.0 * math.cos(math.pi / sides)
        odd = math.ceil(4.0 * apothem_mm / spacing_mm - 1e-9)
        odd += 1 - odd % 2
        return 4.0 * apothem_mm / odd

    def aperture(self, grid: ap.ApertureGrid) -> np.ndarray:
        """The composite amplitude transmittance on ``grid`` (Kakimoto eq. 5: ``t_o · P``).

        Obstacles are drawn only over the pupil's bounding box: outside it ``P = 0``.

        Parameters
        ----------
        grid
            The pupil-plane grid (:meth:`grid_for`).

        Returns
        -------
        numpy.ndarray
            The transmittance on the grid, 0 (opaque) to 1 (clear).
        """
        t = self._aperture_crop(grid)
        n_crop = t.shape[0]
        full = np.zeros((grid.n, grid.n))
        offset = grid.n // 2 - n_crop // 2
        full[offset : offset + n_crop, offset : offset + n_crop] = t
        return full

    def _prefilter(self) -> tuple[int, int]:
        """The prefilter for the exact pixel integration, whose transfer is then divided out:
        :data:`DIAPHRAGM_PREFILTER` for a diaphragm, alone or behind the lid, a 4-point cross
        screen or an obstacle image, and for a round pupil behind any of them (the whole
        aperture filtered,
        :func:`glarelab.glare.models.apertures.aperture_diaphragm_prefiltered`);
        :data:`TRIGONAL_PREFILTER` behind a trigonal cross screen; the one-sample box for a
        round pupil alone, and with lashes or particles, whose edges are drawn with the
        one-sample ramp (lashes and particles make the grid fine: 12 samples across them).
        ``aperture_grid='fast'`` draws every aperture with the one-sample box (the drawing
        before the prefilters, 1.3-30 times faster; its error in display codes is in
        docs/speed-accuracy.md)."""
        if self.aperture_grid == "fast" or self.eyelashes or self.particles:
            return ap.PREFILTER_BOX
        if self.cross_screen == "trigonal":
            return TRIGONAL_PREFILTER
        if self.diaphragm_sides is not None:
            return DIAPHRAGM_PREFILTER
        if self.eyelid or self.cross_screen is not None or self.obstacle_image is not None:
            return DIAPHRAGM_PREFILTER
        return ap.PREFILTER_BOX

    def _aperture_crop(
        self, grid: ap.ApertureGrid, prefilter: tuple[int, int] = ap.PREFILTER_BOX
    ) -> np.ndarray:
        """The aperture over the pupil's bounding box (odd size, centred on ``grid``'s centre),
        the diaphragm drawn with ``prefilter``.

        Raises
        ------
        ValueError
            If it passes less than :data:`LEAST_OPEN_SHARE` of the round pupil's light (an
            obstacle image opaque over the whole pupil): the kernel would hold no light and
            the glare would vanish without a word.
        """
        t = self._drawn_aperture(grid, prefilter)
        open_mm2 = float(np.abs(t).sum()) * grid.spacing_mm**2
        if open_mm2 < LEAST_OPEN_SHARE * math.pi * (self.pupil_diameter / 2.0) ** 2:
            raise ValueError(
                "the aperture passes no light: the obstacle image (or lid, lashes, particles) "
                f"is opaque over the whole {self.pupil_diameter:g} mm pupil"
            )
        return t

    def _drawn_aperture(self, grid: ap.ApertureGrid, prefilter: tuple[int, int]) -> np.ndarray:
        """:meth:`_aperture_crop` as drawn, unchecked."""
        rng_lashes, rng_particles = np.random.default_rng(self.seed).spawn(2)
        diameter = self.pupil_diameter
        n_crop = min(grid.n, 2 * (math.ceil(diameter / 2 / grid.spacing_mm) + 2) + 1)
        crop = ap.ApertureGrid(n_crop, grid.spacing_mm)
        shift = self.obstacle_distance_mm * math.tan(math.radians(self.source_x_deg))
        together = (
            prefilter != ap.PREFILTER_BOX
            and (self.eyelid or self.cross_screen is not None or self.obstacle_image is not None)
            and not (self.eyelashes or self.particles)
        )
        if together:  # the lid, the cross screen and the image under the pupil's prefilter
            return ap.aperture_diaphragm_prefiltered(
                crop,
                diameter,
                self.diaphragm_sides,
                rotation_deg=self.diaphragm_rotation_deg,
                eyelid=self.eyelid,
                eyelid_shift_x_mm=shift,
                cross_screen=self.cross_screen,
                obstacle_image=self.obstacle_image,
                obstacle_spacing_mm=self.obstacle_spacing_mm,
                prefilter=prefilter,
            )
        if self.diaphragm_sides is None:
            t = ap.aperture_pupil(crop, diameter)
        else:
            t = ap.aperture_diaphragm(
                crop,
                diameter,
                self.diaphragm_sides,
                rotation_deg=self.diaphragm_rotation_deg,
                prefilter=prefilter,
            )
        if self.eyelid:
            t = t * ap.aperture_eyelid(crop, shift_x_mm=shift)
        if self.eyelashes:
            t = t * ap.aperture_eyelashes(
                crop,
                rng=rng_lashes,
                count=self.eyelash_count,
                thickness_mm=self.eyelash_thickness_mm,
                curvature=self.eyelash_curvature,
                eye=self.eye,
                shift_x_mm=shift,
            )
        if self.particles:
            t = t * ap.aperture_particles(
                crop, rng=rng_particles, count=self.particles, size_mm=self.particle_size_mm
            )
        if self.cross_screen is not None:
            t = t * ap.aperture_cross_screen(crop, self.cross_screen)
        if self.obstacle_image is not None:
            t = t * ap.aperture_image_cover(crop, self.obstacle_image, self.obstacle_spacing_mm)
        return t

    # --- PSFs ---------------------------------------------------------------------------

    def monochromatic_kernels(
        self, pixel_deg: float, shape: tuple[int, int]
    ) -> tuple[np.ndarray, np.ndarray]:
        """Kernels ``(n_wavelengths, KH, KW)`` on ``pixel_deg``, one per wavelength, and the
        wavelengths, each the fraction of the light through the aperture in each pixel
        (times the pupil's share of the light under ``pupil_convention='Luidolt2020'``).

        ``pixel_integration='exact'`` integrates each wavelength's PSF over the pixels
        (:func:`glarelab.glare.models.fraunhofer.pixel_integrated_psf`; one autocorrelation serves
        every wavelength unless the Fresnel term differs between them, 'reference' with
        ``fresnel``); ``'rebin'`` samples the PSF by FFT and rebins the samples, 'reference'
        transforming once per wavelength and 'scaled' once in all.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.

        Returns
        -------
        kernels : numpy.ndarray
            ``(n_wavelengths, KH, KW)``, fractions of each wavelength's light.
        wavelengths : numpy.ndarray
            The wavelengths, nm.
        """
        kernels, wavelengths, _ = self._monochromatic(pixel_deg, shape)
        return kernels, wavelengths

    def _monochromatic(
        self, pixel_deg: float, shape: tuple[int, int]
    ) -> tuple[np.ndarray, np.ndarray, float]:
        """:meth:`monochromatic_kernels` and the share of the source's light they admit
        (:meth:`pupil_share`; 1 under ``'unit-energy'``)."""
        pixel_deg = check_pixel_deg(pixel_deg)
        shape = check_kernel_shape(shape)
        grid = self.grid_for(pixel_deg, shape)
        d = self.fresnel_distance_mm if self.fresnel else None
        wavelengths = self._wavelengths()
        check_choice("spectral", self.spectral, SPECTRAL_METHODS)
        kernels = np.empty((wavelengths.size, *shape))
        if self.pixel_integration == "exact":
            reach_deg = self._extent_deg(pixel_deg, shape)
            prefilter = self._prefilter()
            image = self.obstacle_image is not None and prefilter != ap.PREFILTER_BOX
            parts = IMAGE_TRANSFER_PARTS if image else 1
            t = self._aperture_crop(grid, prefilter)
            per_wavelength = self.fresnel and self.spectral != "scaled"
            acf = None
            if not per_wavelength:
                field_ = t if d is None else _fresnel_field(t, grid.spacing_mm, 575.0, d)
                acf = aperture_autocorrelation(field_, grid.spacing_mm)
            for i, wavelength in enumerate(wavelengths):
                if per_wavelength:
                    field_ = _fresnel_field(t, grid.spacing_mm, float(wavelength), d)
                    acf = aperture_autocorrelation(field_, grid.spacing_mm)
                kernels[i] = pixel_integrated_psf(
                    acf,
                    float(wavelength),
                    pixel_deg,
                    shape,
                    reach_deg=reach_deg,
                    edge_transfer=True,
                    prefilter=prefilter,
                    transfer_parts=parts,
                )
            open_area_mm2 = float(np.abs(t).sum()) * grid.spacing_mm**2
        elif self.pixel_integration == "rebin":
            t = self.aperture(grid)
            open_area_mm2 = float(np.abs(t).sum()) * grid.spacing_mm**2
            if self.spectral == "scaled":
                base = psf_fraunhofer(
                    t, grid.spacing_mm, LUIDOLT2020_REFERENCE_NM, fresnel_distance_mm=d
                )
                # one contiguous crop wide enough for the shortest wavelength serves them all
                spacings = base.spacing_deg * wavelengths / LUIDOLT2020_REFERENCE_NM
                crop = np.ascontiguousarray(
                    _crop_to_reach(base.values, float(spacings.min()), pixel_deg, shape)
                )
                for i, spacing in enumerate(spacings):
                    kernels[i] = _rebin_cropped(crop, float(spacing), pixel_deg, shape)
            else:
                for i, wavelength in enumerate(wavelengths):
                    psf = psf_fraunhofer(t, grid.spacing_mm, wavelength, fresnel_distance_mm=d)
                    kernels[i] = rebin(psf.values, psf.spacing_deg, pixel_deg, shape)
        else:
            raise ValueError(
                f"pixel_integration must be one of {PIXEL_INTEGRATION_METHODS}; "
                f"got {self.pixel_integration!r}"
            )
        share = self.pupil_share(open_area_mm2)
        kernels *= share
        return kernels, wavelengths, share

    def pupil_share(self, open_area_mm2: float | None = None) -> float:
        """The factor on the unit-energy PSF that ``pupil_convention`` asks for.

        1 for ``'unit-energy'``; for ``'Luidolt2020'`` the open area of the aperture over the
        area of the 8 mm disc the particles are spread over (Luidolt's largest pupil, §5.2.1
        ii): a 2 mm pupil 1/16, an 8 mm pupil 1 (less what lids, lashes and particles stop).

        Parameters
        ----------
        open_area_mm2
            The open area of the aperture, mm²; default None: the pupil's disc,
            ``π d² / 4``.

        Returns
        -------
        float
            The factor, 1 for ``'unit-energy'``.

        Raises
        ------
        ValueError
            For an unknown ``pupil_convention``.
        """
        if self.pupil_convention == "unit-energy":
            return 1.0
        if self.pupil_convention == "Luidolt2020":
            if open_area_mm2 is None:
                open_area_mm2 = math.pi * self.pupil_diameter**2 / 4
            return open_area_mm2 / (math.pi * LUIDOLT2020_PUPIL_RANGE_MM[1] ** 2 / 4)
        raise ValueError(
            f"pupil_convention must be one of {PUPIL_CONVENTIONS}; got {self.pupil_convention!r}"
        )

    def halo(self) -> str:
        return "none in this model"

    def kernel(self, pixel_deg: float, shape: tuple[int, int], *, colour: bool = False) -> Kernel:
        """The glare kernel on ``pixel_deg`` pixels: luminance ``(KH, KW)`` or RGB
        ``(KH, KW, 3)`` in the display primaries of ``spectrum``.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        colour
            Whether a kernel per colour channel ``(KH, KW, 3)`` is wanted instead of the
            luminance kernel ``(KH, KW)``; default False.

        Returns
        -------
        Kernel
            The kernel, each channel summing to its PSF energy inside the support, with its
            energy account: ``energy_outside`` is the light beyond the support as a fraction
            of the source's. Under ``pupil_convention='Luidolt2020'`` the kernel admits only
            the pupil's share of the light (``description['admitted_share']``,
            :meth:`pupil_share`), so it sums to that share less ``energy_outside``; the rest
            never entered the eye and is not booked as outside.
        """
        kernels, wavelengths, share = self._monochromatic(pixel_deg, shape)
        if self.spectral == "kakimoto":
            rgb = kernels  # Kakimoto §3.2: each wavelength is one display channel
            weights_y = _luminance_weights(self.spectrum.colourspace)
            values = np.tensordot(weights_y, rgb, axes=1)[None] if not colour else rgb
        else:
            weights = self.spectrum.channel_weights("RGB" if colour else "Y")
            values = np.tensordot(weights, kernels, axes=1)
        clipped = 0.0
        if colour:
            negative = np.minimum(values, 0.0)
            clipped = float(-negative.sum() / max(values.sum(), 1e-300))
            sums = values.sum(axis=(1, 2))
            values = np.maximum(values, 0.0)
            values *= (sums / values.sum(axis=(1, 2)))[:, None, None]
        # beyond the support, as a fraction of the source's light: under 'Luidolt2020' the
        # kernel admits only the pupil's share, and the rest never entered the eye
        energy_outside = share - values.sum(axis=(1, 2))
        description = {
            "model": "WaveOpticsGlare",
            "admitted_share": share,
            **{k: v for k, v in asdict(self).items() if k not in ("spectrum", "obstacle_image")},
            "obstacle_image": _obstacle_digest(self),
            "spectrum": asdict(self.spectrum),
            "pupil_diameter_mm": self.pupil_diameter,
            "wavelengths_nm": wavelengths.tolist(),
            "out_of_gamut_clipped": clipped,
        }
        return Kernel(
            values=values[0] if not colour else np.moveaxis(values, 0, -1),
            pixel_deg=pixel_deg,
            energy_outside=float(energy_outside[0]) if not colour else energy_outside,
            quadrature_error=0.0,
            description=description,
        )

    def at_source(self, source_x_deg: float) -> WaveOpticsGlare:
        """The same eye with the light source at another horizontal angle.

        Parameters
        ----------
        source_x_deg
            The source's horizontal angle from the line of sight, degrees.

        Returns
        -------
        WaveOpticsGlare
            A copy with that source position; the model itself without eyelashes and eyelid,
            whose kernel does not depend on it.
        """
        if not (self.eyelashes or self.eyelid):  # nothing the angle moves: the same kernel
            check_in_range("source_x_deg", source_x_deg, -60.0, 60.0, unit="deg")
            return self
        return replace(self, source_x_deg=source_x_deg)

    def kernel_set(
        self,
        pixel_deg: float,
        shape: tuple[int, int],
        positions_deg: list[float],
        *,
        colour: bool = False,
    ) -> dict[float, Kernel]:
        """Kernels keyed by source position, precomputed as Kakimoto §4.3 does.

        Parameters
        ----------
        pixel_deg
            Visual angle of one pixel in degrees, in [1e-5, 180].
        shape
            Odd kernel shape ``(KH, KW)``, pixels.
        positions_deg
            The sources' horizontal angles, degrees.
        colour
            Whether a kernel per colour channel ``(KH, KW, 3)`` is wanted instead of the
            luminance kernel ``(KH, KW)``; default False.

        Returns
        -------
        dict of float to Kernel
            One kernel per position.
        """
        return {
            float(x): self.at_source(x).kernel(pixel_deg, shape, colour=colour)
            for x in positions_deg
        }


def _lab(rgb: np.ndarray, colourspace: str, scale: float) -> np.ndarray:
    xyz = colour.RGB_to_XYZ(rgb * scale, colourspace, apply_cctf_decoding=False)
    white = colour.RGB_COLOURSPACES[colourspace].whitepoint
    return colour.XYZ_to_Lab(xyz, white)


def compare_spectral_methods(
    model: WaveOpticsGlare, pixel_deg: float, shape: tuple[int, int]
) -> list[dict]:
    """Time the three spectral methods and measure their colour error against 'reference'.

    The error is CIEDE2000 between each kernel pixel's colour and the reference's, with every
    pixel shown at a luminance of 20 % of the display white (the reference pixel's luminance;
    the method's pixel keeps its luminance ratio to it), averaged with the reference energy as
    weight, and the maximum, over the pixels at 1e-4 of the reference's peak or above.

    Parameters
    ----------
    model
        The wave-optics model; its ``spectral`` method is replaced by each in turn. Under
        ``pixel_integration='exact'`` without ``fresnel`` the reference is the scaled copies,
        exact there (:class:`WaveOpticsGlare` refuses ``'reference'`` as the same kernel).
    pixel_deg
        Visual angle of one pixel in degrees, in [1e-5, 180].
    shape
        Odd kernel shape ``(KH, KW)``, pixels.

    Returns
    -------
    list of dict
        ``method``, ``seconds``, ``delta_e_mean``, ``delta_e_max``, ``luminance_error``
        (sum of absolute luminance differences, relative to the reference's sum).
    """
    kernels = {}
    seconds = {}
    exact = model.pixel_integration == "exact" and not model.fresnel
    for method in SPECTRAL_METHODS:
        variant = replace(model, spectral="scaled" if method == "reference" and exact else method)
        start = time.perf_counter()
        kernels[method] = variant.kernel(pixel_deg, shape, colour=True).values
        seconds[method] = time.perf_counter() - start
    rows = []
    for method in SPECTRAL_METHODS:
        error = kernel_colour_error(
            kernels["reference"], kernels[method], model.spectrum.colourspace
        )
        rows.append({"method": method, "seconds": seconds[method], **error})
    return rows


def kernel_colour_error(reference: np.ndarray, values: np.ndarray, colourspace: str) -> dict:
    """CIEDE2000 between two RGB kernels ``(KH, KW, 3)`` of the same shape.

    Every pixel is shown at a luminance of 20 % of the display white (the reference pixel's
    luminance; the other keeps its luminance ratio to it); the mean is weighted by the
    reference energy, over the pixels at 1e-4 of the reference's peak or above.

    Parameters
    ----------
    reference
        The reference RGB kernel, ``(KH, KW, 3)``, linear.
    values
        The kernel compared, same shape.
    colourspace
        The name of the kernels' RGB colourspace in colour-science (``'sRGB'``, ...).

    Returns
    -------
    dict
        ``delta_e_mean``, ``delta_e_max``, ``luminance_error`` (sum of absolute luminance
        differences, relative to the reference's sum).
    """
    weights_y = _luminance_weights(colourspace)
    y_ref = reference @ weights_y
    significant = y_ref >= 1e-4 * y_ref.max()
    scale = 0.2 / np.where(y_ref > 0, y_ref, 1.0)
    lab_ref = _lab(reference[significant], colourspace, scale[significant][:, None])
    lab = _lab(values[significant], colourspace, scale[significant][:, None])
    delta = colour.delta_E(lab_ref, lab, method="CIE 2000")
    y = values @ weights_y
    return {
        "delta_e_mean": float(np.average(delta, weights=y_ref[significant])),
        "delta_e_max": float(delta.max()),
        "luminance_error": float(np.abs(y - y_ref).sum() / y_ref.sum()),
    }


def _obstacle_digest(model: WaveOpticsGlare) -> str | None:
    """A model's obstacle image as its kernel's description names it: None, or ``'user
    image'`` and the sha256 of its shape, dtype and values."""
    image = model.obstacle_image
    if image is None:
        return None
    return f"user image, sha256 {array_sha256(image)}"
