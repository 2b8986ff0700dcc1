"""The papers' own conditions: Luidolt's pupil convention, Spencer's renormalisation, the
Spencer protocol's regime and display."""

import math
import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose

from glarelab.glare import VosGlare, WaveOpticsGlare
from glarelab.glare.models.eye import regime
from glarelab.protocols import load_protocol, pixel_deg

PARTICLES = {"eyelashes": False, "eyelid": False, "particles": 1000, "spectral": "kakimoto"}
PIXEL_DEG, SHAPE = 0.02, (41, 41)  # a 0.82° kernel: small, and wide enough for the glow


def _beyond(kernel: np.ndarray, radius_deg: float) -> float:
    y, x = np.indices(kernel.shape) - kernel.shape[0] // 2
    return float(kernel[np.hypot(x, y) * PIXEL_DEG > radius_deg].sum())


def test_luidolt_pupil_convention_gives_more_glare_for_a_larger_pupil():
    # Luidolt §5.2.4: "A bigger pupil admits more light into the eye than a smaller one.
    # Therefore, the resulting glare is more intense" (Fig. 5.6: 2, 4, 6, 8 mm)
    pupils = (2.0, 4.0, 6.0, 8.0)
    glow = {}
    for convention in ("unit-energy", "Luidolt2020"):
        glow[convention] = []
        for pupil_mm in pupils:
            model = WaveOpticsGlare(pupil_mm=pupil_mm, **PARTICLES, pupil_convention=convention)
            glow[convention].append(_beyond(model.kernel(PIXEL_DEG, SHAPE).values, 0.05))
    assert np.all(np.diff(glow["Luidolt2020"]) > 0)
    # the unit-energy PSF only narrows: its glow beyond 0.05° falls as the pupil grows
    assert np.all(np.diff(glow["unit-energy"]) < 0)
    # Luidolt's kernel is the unit-energy one times the open area over the 8 mm disc's
    shares = np.array(glow["Luidolt2020"]) / np.array(glow["unit-energy"])
    assert_allclose(shares, (np.array(pupils) / 8.0) ** 2, rtol=0.03)  # less what particles stop


def test_luidolt_share_is_the_open_area_and_names_its_range():
    model = WaveOpticsGlare(pupil_mm=4.0, eyelashes=False, eyelid=False, particles=0,
                            pupil_convention="Luidolt2020")  # fmt: skip
    unit = WaveOpticsGlare(pupil_mm=4.0, eyelashes=False, eyelid=False, particles=0)
    k, u = model.kernel(0.05, (21, 21)), unit.kernel(0.05, (21, 21))
    assert_allclose(k.values, u.values * model.pupil_share(), rtol=2e-3)
    assert_allclose(model.pupil_share(), 0.25, rtol=1e-12)  # (4 / 8)² for the round pupil
    # the rest never entered the eye: only light beyond the support is booked as outside
    share = k.description["admitted_share"]
    assert_allclose(share, 0.25, rtol=2e-3)  # the drawn disc's area
    assert_allclose(k.values.sum() + k.energy_outside, share, atol=1e-9)
    assert_allclose(k.energy_outside, share * u.energy_outside, rtol=1e-6)
    assert unit.pupil_share() == 1.0
    with pytest.warns(UserWarning, match="outside Luidolt's 2-8 mm range"):
        WaveOpticsGlare(pupil_mm=9.0, pupil_convention="Luidolt2020")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        WaveOpticsGlare(pupil_mm=9.0)  # the unit-energy PSF has no such range
    with pytest.raises(ValueError, match="pupil_convention must be one of"):
        WaveOpticsGlare(pupil_convention="Ritschel")
    with pytest.raises(ValueError, match="pixel_integration must be one of"):
        WaveOpticsGlare(pixel_integration="fft")


@pytest.mark.parametrize("vos_regime", ["photopic", "scotopic"])
def test_spencer_renormalisation_makes_every_filter_sum_to_one(vos_regime):
    # Spencer §3.2: "calculate each filter proportional to a given function, and then
    # renormalize the filter so that all pixels sum to one"
    shape = (121, 121)
    psf = VosGlare(regime=vos_regime).kernel(0.05, shape)
    spencer = VosGlare(regime=vos_regime, normalisation="Spencer1995").kernel(0.05, shape)
    assert psf.energy_outside > 0.02  # a 6° kernel leaves out the far corona
    assert abs(spencer.energy_outside) < 1e-12
    assert_allclose(spencer.values.sum(), 1.0, rtol=1e-12)
    # every component is scaled up by its own share: the far glow most, the core least
    centre = shape[0] // 2
    assert spencer.values[centre, centre] / psf.values[centre, centre] < 1.03
    assert spencer.values[centre, -1] / psf.values[centre, -1] > 1.2
    parts = VosGlare(regime=vos_regime, normalisation="Spencer1995").parts(0.05, shape)
    assert_allclose(parts["core"].sum(), 1.0, rtol=1e-12)
    assert_allclose(parts["scatter"].sum(), sum(parts["weights"][1:3]), rtol=1e-12)
    assert VosGlare(normalisation="Spencer1995").tail_bound(0.05, np.arange(3)) is None
    with pytest.raises(ValueError, match="normalisation must be one of"):
        VosGlare(normalisation="unit")


def test_spencer_protocol_uses_the_papers_regime_and_display():
    protocol = load_protocol("spencer1995")
    display = protocol["display"]
    assert display["max_cd_m2"] == 50.0  # §1: "approximately 50 cd/m^2"
    parameters = protocol["glare"]["parameters"]
    # §4: a darkened room and a black field: the field is the display's black, or the lamp
    # scene (mean 0.3 cd/m²); the regime is §3.1's rule for that luminance
    assert parameters["regime"] == regime(display["black_cd_m2"]) == "mesopic"
    assert parameters["normalisation"] == "Spencer1995"
    # what the change means on the protocol's own kernel: more light beyond 1°
    p = pixel_deg(protocol)
    shape = (2 * protocol["stimulus"]["window_px"] - 1,) * 2
    y, x = np.indices(shape) - shape[0] // 2
    far = np.hypot(x, y) * p > 1.0
    before = VosGlare(regime="photopic").kernel(p, shape).values[far].sum()
    after = VosGlare(regime="mesopic", normalisation="Spencer1995").kernel(p, shape).values
    assert after[far].sum() > 1.5 * before
    assert math.isclose(after.sum(), 1.0, rel_tol=1e-12)


def test_luidolt_convention_follows_the_night_pupil():
    # render_night sets the pupil from the adapted luminance: Luidolt's kernel then holds more
    # of the source's light in the dark (§5.2.1 ii), the unit-energy one the same
    from glarelab.glare.night import adapted_model

    for convention, grows in (("Luidolt2020", True), ("unit-energy", False)):
        model = WaveOpticsGlare(pupil_convention=convention)
        dark, bright = (adapted_model(model, level) for level in (0.01, 100.0))
        assert dark.pupil_convention == convention
        assert dark.pupil_mm > bright.pupil_mm
        assert (dark.pupil_share() > bright.pupil_share()) is grows
