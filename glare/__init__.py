"""Glare around bright regions of linear HDR luminance images.

Models: :class:`GaussianGlare` (Yoshida et al. 2008), :class:`VosGlare` (Vos 1984 eye PSF
as used by Spencer et al. 1995), :class:`WaveOpticsGlare` (Kakimoto et al. 2004, with pupil,
particles and Fresnel term as in Luidolt 2020) and :class:`HybridGlare` (diffraction plus Vos
scattering). Digitise one with :func:`kernel` / :func:`digitise_kernel`,
apply it with :func:`add_glare` / :func:`render_glare`, or to many images of one shape with
a :class:`GlareRenderer`. The eye state is in :mod:`glare.eye`,
the PSF components in :mod:`glare.vos`.
"""

from . import apertures, eye, vos, wave
from .base import TailBound
from .digitise import Kernel, kernel_shape_for
from .display import Display
from .eye import pupil_diameter_mm, regime
from .flare import flare_line_pattern
from .models import (
    GLARE_MODELS,
    GaussianGlare,
    GlareModel,
    HybridGlare,
    VosGlare,
    digitise_kernel,
    kernel,
    make_model,
)
from .plan import GlarePlan, plan_glare
from .render import L_DMAX_YOSHIDA2008_CD_M2, add_glare, render_glare, render_planned
from .renderer import GlareRenderer, GlareResult, PlannedGlare
from .spectral import HaloSpectrum, Spectrum
from .wave import WaveOpticsGlare

__all__ = [
    "GLARE_MODELS",
    "L_DMAX_YOSHIDA2008_CD_M2",
    "Display",
    "GaussianGlare",
    "GlareModel",
    "GlarePlan",
    "GlareRenderer",
    "GlareResult",
    "HaloSpectrum",
    "HybridGlare",
    "Kernel",
    "PlannedGlare",
    "Spectrum",
    "TailBound",
    "VosGlare",
    "WaveOpticsGlare",
    "add_glare",
    "apertures",
    "digitise_kernel",
    "eye",
    "flare_line_pattern",
    "kernel",
    "kernel_shape_for",
    "make_model",
    "plan_glare",
    "pupil_diameter_mm",
    "regime",
    "render_glare",
    "render_planned",
    "vos",
    "wave",
]
