"""A stimulus set as its display shows it is one concept: the simulated observers' view of it
and the report's are the same luminances, ``decode(encode(image))``."""

import numpy as np
from numpy.testing import assert_array_equal

from glarelab.analysis.stimulus_figures import VerifiedSet
from glarelab.observers.looking import ObservedSet
from glarelab.protocols import load_protocol
from glarelab.stimuli.shown import ShownSet
from glarelab.stimuli.stimulus_set import StimulusSet, cached_stimulus_set


def test_the_observers_and_the_report_see_the_same_luminances():
    protocol = load_protocol("yoshida2008")
    folder = cached_stimulus_set(protocol, progress=None)
    observed, verified = ObservedSet(StimulusSet(folder)), VerifiedSet(folder, protocol)
    assert isinstance(observed, ShownSet) and isinstance(verified, ShownSet)
    name = "reference_gaussian_F"
    shown = observed.luminance(name)
    assert_array_equal(shown, verified.luminance(name))
    assert_array_equal(shown, observed.shows([(name, 1.0)]))  # composed as a session composes
    calibration = verified.calibration
    codes, _ = calibration.encode(StimulusSet(folder).image(name))
    assert_array_equal(shown, calibration.decode(codes))
    assert float(np.max(shown)) <= calibration.max_cd_m2
