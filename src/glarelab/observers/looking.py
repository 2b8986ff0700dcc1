"""What a simulated observer sees: a stimulus set's images as its display shows them.

The set's images are luminances in cd/m²; the display shows the codes its calibration gives
them, so an observer looks at ``decode(encode(image))``: quantised to the display's codes and
clipped to its range, as a participant would see them. Images are composed from the set's
components exactly as the session composes them (:func:`glarelab.stimuli.stimulus_set.compose`).

A percept depends only on the image, the brightness model and the geometry judged, so it is
remembered here: observers given the same :class:`ObservedSet` (the simulated participants of
a power analysis) compute each percept once.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from glarelab.stimuli.shown import ShownSet
from glarelab.stimuli.stimulus_set import StimulusSet

__all__ = ["ObservedSet"]

CACHE_SIZE = 64  # images kept: a study's references and staircases' comparisons repeat


class ObservedSet(ShownSet):
    """A stimulus set as its display shows it to the simulated observers
    (:class:`glarelab.stimuli.shown.ShownSet`), with the images they are shown and the percepts
    they share remembered.

    Parameters
    ----------
    stimuli
        The set, read back (:class:`glarelab.stimuli.stimulus_set.StimulusSet`).
    """

    def __init__(self, stimuli: StimulusSet):
        super().__init__(stimuli)
        self._shown: OrderedDict[tuple, np.ndarray] = OrderedDict()
        self._percepts: dict[tuple, object] = {}

    def shows(self, terms) -> np.ndarray:
        """The luminance (cd/m²) the display shows for an image given as ``[(name, weight)]``.

        Parameters
        ----------
        terms
            The image as ``[(name, weight)]`` of the set's images
            (:func:`glarelab.stimuli.stimulus_set.compose`).

        Returns
        -------
        numpy.ndarray
            ``decode(encode(image))`` through the set's calibration, cd/m² (the last images
            shown are kept).
        """
        key = tuple((name, float(weight)) for name, weight in terms)
        if key in self._shown:
            self._shown.move_to_end(key)
            return self._shown[key]
        codes, _ = self.calibration.encode(self.set.compose(key))
        shown = self.calibration.decode(codes)
        self._shown[key] = shown
        if len(self._shown) > CACHE_SIZE:
            self._shown.popitem(last=False)
        return shown

    def percept(self, model, terms, **geometry):
        """What ``model`` (a :class:`glarelab.observers.brightness.BrightnessModel`) perceives of
        the image ``[(name, weight)]`` with ``geometry`` (its ``percept`` keywords); computed once
        per model, image and geometry.

        Parameters
        ----------
        model
            The brightness model.
        terms
            The image as ``[(name, weight)]`` of the set's images
            (:func:`glarelab.stimuli.stimulus_set.compose`).
        geometry
            The region judged, as ``model.percept`` takes it (centre, diameter, ...).

        Returns
        -------
        object
            What ``model.percept`` returns.
        """
        image = tuple((name, float(weight)) for name, weight in terms)
        key = (model, image, tuple(sorted(geometry.items())))
        if key not in self._percepts:
            self._percepts[key] = model.percept(self.shows(image), **geometry)
        return self._percepts[key]
