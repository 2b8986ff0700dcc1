import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from glarelab.glare.models import eye


def test_pupil_is_about_3_mm_at_10_cd_m2():
    # Spencer 1995 §3.1.1: "about 3mm for L = 10 cd/m²"; hand calculation 4.9 - 3 tanh(0.8)
    assert_allclose(eye.pupil_diameter_mm(10.0), 4.9 - 3 * math.tanh(0.8), rtol=1e-12)
    assert abs(eye.pupil_diameter_mm(10.0) - 3.0) < 0.1


def test_pupil_limits_at_darkness_and_extreme_light():
    # tanh(-inf) = -1: 4.9 + 3 = 7.9 mm in the dark; 1e9 cd/m²: 4.9 - 3 tanh(4) = 1.902 mm
    assert eye.pupil_diameter_mm(0.0) == pytest.approx(7.9, abs=1e-12)
    assert eye.pupil_diameter_mm(1e9) == pytest.approx(4.9 - 3 * math.tanh(4.0), rel=1e-12)
    assert eye.pupil_diameter_mm(1e9) > 1.9


def test_pupil_accepts_arrays_and_keeps_their_shape():
    field = np.array([[0.001, 0.1], [10.0, 1000.0]])
    diameters = eye.pupil_diameter_mm(field)
    assert diameters.shape == (2, 2)
    assert_allclose(diameters[1, 0], eye.pupil_diameter_mm(10.0), rtol=1e-15)
    # a stack of frames (3-D) was refused as "must be a 2-D (H, W) array", though the
    # docs say "scalar or array"
    stack = np.stack([field, 10 * field, field / 10])
    stacked = eye.pupil_diameter_mm(stack)
    assert stacked.shape == (3, 2, 2)
    assert_allclose(stacked[0], diameters, rtol=0, atol=0)
    assert_allclose(stacked[1, 0, 1], eye.pupil_diameter_mm(1.0), rtol=1e-15)


@given(
    st.floats(0.0, 1e9, allow_nan=False),
    st.floats(0.0, 1e9, allow_nan=False),
)
def test_pupil_shrinks_as_the_field_brightens(a, b):
    low, high = sorted((a, b))
    assert eye.pupil_diameter_mm(low) >= eye.pupil_diameter_mm(high)
    assert 1.9 <= eye.pupil_diameter_mm(high) <= 7.9


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf")])
def test_pupil_rejects_impossible_luminance(bad):
    with pytest.raises(ValueError, match="field_luminance_cd_m2"):
        eye.pupil_diameter_mm(bad)


@pytest.mark.parametrize("text", ["100", b"100", np.array(["100"]), [True, False]])
def test_pupil_rejects_what_is_not_a_number(text):
    # pupil_diameter_mm('100') gave 2.399 mm: the string was read as a number
    with pytest.raises((TypeError, ValueError), match=r"^field_luminance_cd_m2 must .*numbers"):
        eye.pupil_diameter_mm(text)


@pytest.mark.parametrize(
    ("luminance", "expected"),
    [
        (0.0, "scotopic"),
        (0.00999, "scotopic"),
        (0.01, "mesopic"),  # Spencer §3.1: "the range 0.01-3 cd/m² is the mesopic region"
        (3.0, "mesopic"),
        (3.0001, "photopic"),
        (1e9, "photopic"),
    ],
)
def test_regime_boundaries(luminance, expected):
    assert eye.regime(luminance) == expected


def test_regime_rejects_arrays_and_negative_values():
    with pytest.raises(ValueError, match="scalar"):
        eye.regime(np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match=r"field_luminance_cd_m2 must be >= 0"):
        eye.regime(-0.5)


def test_halo_needs_a_pupil_over_3_mm_and_mesopic_fields_give_one():
    # Spencer §3.1.1: halo only for pupils > 3 mm; the brightest mesopic field (3 cd/m²)
    # still has a 3.3 mm pupil, so the mesopic PSF (with halo) is consistent with it.
    assert eye.pupil_diameter_mm(eye.MESOPIC_UPPER_CD_M2) > eye.HALO_PUPIL_MM


def test_a_masked_luminance_is_refused_not_its_masked_value_used():
    """np.asarray dropped the mask: the masked element got a pupil of its hidden value."""
    with pytest.raises(ValueError, match="masked array"):
        eye.pupil_diameter_mm(np.ma.array([10.0, 100.0], mask=[False, True]))


@pytest.mark.parametrize("shape", [(0,), (0, 3), (2, 0)])
def test_no_luminances_give_no_diameters(shape):
    # as acuity_cpd and the other night functions do (it was refused, naming shape (1, 0))
    assert eye.pupil_diameter_mm(np.zeros(shape)).shape == shape


def test_ragged_rows_and_an_empty_array_of_bools_are_named_for_what_they_are():
    with pytest.raises(ValueError, match=r"^field_luminance_cd_m2 must be an array of numbers"):
        eye.regime([[1.0], [1.0, 2.0]])  # numpy's own 'setting an array element' message
    with pytest.raises(ValueError, match=r"luminances, numbers in cd/m²; got an empty array of"):
        eye.pupil_diameter_mm(np.array([], bool))  # was 'no pixel; got shape (1, 0)'
