"""Night vision around the glare: adaptation, acuity, scotopic colour, and the pipeline.

Temporal adaptation (:mod:`glarelab.glare.night.adaptation`), acuity loss
(:mod:`glarelab.glare.night.acuity`), scotopic colour (:mod:`glarelab.glare.night.scotopic`),
and all of them with glare in Luidolt's order (:func:`render_night`, in
:mod:`glarelab.glare.night.pipeline`). The pipeline is imported on first use, so that a module
needing only the acuity model does not pull in the glare models with it.
"""

import importlib

_PIPELINE = ("EFFECTS", "PUPIL_STEP_MM", "NightResult", "adapted_model", "render_night")
__all__ = list(_PIPELINE)


def __getattr__(name: str):
    if name in _PIPELINE:
        return getattr(importlib.import_module("glarelab.glare.night.pipeline"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
