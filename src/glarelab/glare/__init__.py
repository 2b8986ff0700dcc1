"""Glare around bright regions of linear HDR luminance images.

Models: :class:`GaussianGlare` (Yoshida et al. 2008), :class:`VosGlare` (Vos 1984 eye PSF
as used by Spencer et al. 1995), :class:`WaveOpticsGlare` (Kakimoto et al. 2004, with pupil,
particles and Fresnel term as in Luidolt 2020) and :class:`HybridGlare` (diffraction plus Vos
scattering). Digitise one with :func:`kernel` / :func:`digitise_kernel`,
apply it with :func:`add_glare` / :func:`render_glare`, or to many images of one shape with
a :class:`GlareRenderer`. The eye state is in :mod:`glarelab.glare.models.eye`,
the PSF components in :mod:`glarelab.glare.models.vos`.

Night vision around the glare (Spencer 1995 §5, Luidolt 2020 ch. 5): temporal adaptation
(:mod:`glarelab.glare.night.adaptation`), acuity loss (:mod:`glarelab.glare.night.acuity`),
scotopic colour (:mod:`glarelab.glare.night.scotopic`), and all of them with glare in Luidolt's
order, :func:`render_night`.
"""

import importlib

from glarelab.glare.models import (
    GLARE_MODELS,
    GaussianGlare,
    GlareModel,
    VosGlare,
    digitise_kernel,
    eye,
    kernel,
    make_model,
    vos,
)
from glarelab.glare.models.base import TailBound
from glarelab.glare.models.digitise import Kernel, kernel_shape_for
from glarelab.glare.models.eye import pupil_diameter_mm, regime
from glarelab.glare.models.flare import flare_line_pattern
from glarelab.glare.models.spectral import HaloSpectrum, Spectrum
from glarelab.glare.rendering.display import Display
from glarelab.glare.rendering.plan import GlarePlan, plan_glare
from glarelab.glare.rendering.render import (
    L_DMAX_YOSHIDA2008_CD_M2,
    add_glare,
    render_glare,
    render_planned,
)
from glarelab.glare.rendering.renderer import GlareRenderer, GlareResult, PlannedGlare

# Imported on first use: these need colour-science (which imports matplotlib) or SciPy's
# interpolation and statistics, a second or more that a render of the Vos or the Gaussian
# kernel never needs.
_LAZY_MODULES = {
    "acuity": "glarelab.glare.night.acuity",
    "adaptation": "glarelab.glare.night.adaptation",
    "apertures": "glarelab.glare.models.apertures",
    "cache": "glarelab.glare.models.cache",
    "night": "glarelab.glare.night",
    "scotopic": "glarelab.glare.night.scotopic",
    "wave": "glarelab.glare.models.wave",
}
_LAZY_NAMES = {
    "acuity_blur": "glarelab.glare.night.acuity",
    "blur_sigma_deg": "glarelab.glare.night.acuity",
    "adaptation_luminance": "glarelab.glare.night.adaptation",
    "frame_luminance": "glarelab.glare.night.adaptation",
    "NightResult": "glarelab.glare.night.pipeline",
    "render_night": "glarelab.glare.night.pipeline",
    "scotopic_colour": "glarelab.glare.night.scotopic",
    "WaveOpticsGlare": "glarelab.glare.models.wave",
    "HybridGlare": "glarelab.glare.models.hybrid",
}


def __getattr__(name: str):
    if name in _LAZY_MODULES:
        return importlib.import_module(_LAZY_MODULES[name])
    if name in _LAZY_NAMES:
        return getattr(importlib.import_module(_LAZY_NAMES[name]), name)
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
