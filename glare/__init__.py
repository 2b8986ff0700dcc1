"""Glare around bright regions of linear HDR luminance images.

Models: :class:`GaussianGlare` (Yoshida et al. 2008), :class:`VosGlare` (Vos 1984 eye PSF
as used by Spencer et al. 1995), :class:`WaveOpticsGlare` (Kakimoto et al. 2004, with pupil,
particles and Fresnel term as in Luidolt 2020) and :class:`HybridGlare` (diffraction plus Vos
scattering). Digitise one with :func:`kernel` / :func:`digitise_kernel`,
apply it with :func:`add_glare` / :func:`render_glare`, or to many images of one shape with
a :class:`GlareRenderer`. The eye state is in :mod:`glare.eye`,
the PSF components in :mod:`glare.vos`.

Night vision around the glare (Spencer 1995 §5, Luidolt 2020 ch. 5): temporal adaptation
(:mod:`glare.adaptation`), acuity loss (:mod:`glare.acuity`), scotopic colour
(:mod:`glare.scotopic`), and all of them with glare in Luidolt's order, :func:`render_night`.
"""

from . import acuity, adaptation, apertures, eye, night, scotopic, vos, wave
from .acuity import acuity_blur, blur_sigma_deg
from .adaptation import adaptation_luminance, frame_luminance
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
from .night import NightResult, render_night
from .plan import GlarePlan, plan_glare
from .render import L_DMAX_YOSHIDA2008_CD_M2, add_glare, render_glare, render_planned
from .renderer import GlareRenderer, GlareResult, PlannedGlare
from .scotopic import scotopic_colour
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
    "NightResult",
    "PlannedGlare",
    "Spectrum",
    "TailBound",
    "VosGlare",
    "WaveOpticsGlare",
    "acuity",
    "acuity_blur",
    "adaptation",
    "adaptation_luminance",
    "add_glare",
    "apertures",
    "blur_sigma_deg",
    "digitise_kernel",
    "eye",
    "flare_line_pattern",
    "frame_luminance",
    "kernel",
    "kernel_shape_for",
    "make_model",
    "night",
    "plan_glare",
    "pupil_diameter_mm",
    "regime",
    "render_glare",
    "render_night",
    "render_planned",
    "scotopic",
    "scotopic_colour",
    "vos",
    "wave",
]
