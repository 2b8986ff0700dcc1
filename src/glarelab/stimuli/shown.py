"""A stimulus set as its display shows it.

A session shows an image of the set as the drive codes of the set's calibration (the
manifest's), so what a participant saw is ``decode(encode(image))``: quantised to the display's
bit depth and clipped at its black and maximum. :class:`ShownSet` is that one concept; the
simulated observers look at it (:class:`glarelab.observers.looking.ObservedSet`, which adds
the percepts they share) and a report draws it
(:class:`glarelab.analysis.stimulus_figures.VerifiedSet`, which first checks the set against
its manifest and protocol).
"""

from __future__ import annotations

import numpy as np

from glarelab.display.calibration import Calibration
from glarelab.stimuli.stimulus_set import StimulusSet

__all__ = ["ShownSet"]


class ShownSet:
    """A stimulus set as its display shows it.

    Parameters
    ----------
    stimuli
        The set, read back (:class:`glarelab.stimuli.stimulus_set.StimulusSet`).

    Attributes
    ----------
    set, manifest, geometry
        The set, its manifest and its geometry.
    calibration
        The calibration the set was encoded with (the manifest's).
    """

    def __init__(self, stimuli: StimulusSet):
        self.set = stimuli
        self.manifest: dict = stimuli.manifest
        self.geometry: dict = stimuli.geometry
        self.calibration = Calibration.from_json(
            stimuli.manifest["calibration"], source=f"{stimuli.folder}/manifest.json"
        )

    def luminance(self, name: str) -> np.ndarray:
        """The luminance (cd/m²) the display shows for image ``name``:
        ``decode(encode(image))``.

        Parameters
        ----------
        name
            The image's name in the stimulus set's manifest.

        Returns
        -------
        numpy.ndarray
            The displayed luminance (cd/m²), of the image's shape.
        """
        codes, _report = self.calibration.encode(self.set.image(name))
        return self.calibration.decode(codes)
