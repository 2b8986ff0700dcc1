"""Simulated observers: what they perceive of an image, how they differ and decide, and where
they were fitted.

- :mod:`glarelab.observers.brightness`: the image-computable brightness model (the percept of a
  disk with the glare around it);
- :mod:`glarelab.observers.noise`: how observers differ and decide (gain, settings, questions,
  comparisons), the decisions written once on arrays for the observers and their fit
  (``scripts/fit_observers.py``);
- :mod:`glarelab.observers.fitted_range`: the stimuli the parameters were fitted on, and the
  warning when a study goes beyond them;
- :mod:`glarelab.observers.looking`: a stimulus set as the display shows it to the observers,
  with the percepts they share.

Nothing here knows a paradigm, an engine or a session: each paradigm's simulated participant
(:mod:`glarelab.experiments`) answers its engine's screens with these parts.
"""

from glarelab.observers.brightness import BrightnessModel, Percept
from glarelab.observers.fitted_range import (
    JudgedGlare,
    JudgedStimuli,
    OutsideFittedRangeWarning,
    fitted_range_departures,
    warn_outside_fitted_range,
)
from glarelab.observers.noise import Observer, ObserverNoise, observer_parameters

__all__ = [
    "BrightnessModel",
    "JudgedGlare",
    "JudgedStimuli",
    "Observer",
    "ObserverNoise",
    "OutsideFittedRangeWarning",
    "Percept",
    "fitted_range_departures",
    "observer_parameters",
    "warn_outside_fitted_range",
]
