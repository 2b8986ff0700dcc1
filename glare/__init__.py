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

import importlib

from . import eye, vos
from .base import TailBound
from .digitise import Kernel, kernel_shape_for
from .display import Display
from .eye import pupil_diameter_mm, regime
from .flare import flare_line_pattern
from .models import (
    GLARE_MODELS,
    GaussianGlare,
    GlareModel,
    VosGlare,
    digitise_kernel,
    kernel,
    make_model,
)
from .plan import GlarePlan, plan_glare
from .render import L_DMAX_YOSHIDA2008_CD_M2, add_glare, render_glare, render_planned
from .renderer import GlareRenderer, GlareResult, PlannedGlare
from .spectral import HaloSpectrum, Spectrum

# Imported on first use: these need colour-science (which imports matplotlib) or SciPy's
# interpolation and statistics, a second or more that a render of the Vos or the Gaussian
# kernel never needs.
_LAZY_MODULES = ("acuity", "adaptation", "apertures", "cache", "night", "scotopic", "wave")
_LAZY_NAMES = {
    "acuity_blur": "acuity",
    "blur_sigma_deg": "acuity",
    "adaptation_luminance": "adaptation",
    "frame_luminance": "adaptation",
    "NightResult": "night",
    "render_night": "night",
    "scotopic_colour": "scotopic",
    "WaveOpticsGlare": "wave",
    "HybridGlare": "hybrid",
}


def __getattr__(name: str):
    if name in _LAZY_MODULES:
        return importlib.import_module(f".{name}", __name__)
    if name in _LAZY_NAMES:
        return getattr(importlib.import_module(f".{_LAZY_NAMES[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


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
    "cache",
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
