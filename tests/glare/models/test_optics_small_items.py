"""Smaller items of issue 33: one warning for an age outside 20-70, and render_planned's
default maximum display luminance as the other render functions'."""

import inspect
import warnings

import pytest

from glarelab.glare import VosGlare
from glarelab.glare.rendering import render


def test_an_age_outside_the_papers_span_warns_once():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        VosGlare(age=80).kernel(0.05, (11, 11))
    ages = [w for w in caught if "outside 20-70 years" in str(w.message)]
    assert len(ages) == 1


@pytest.mark.parametrize("name", ["render_planned", "add_glare"])
def test_render_functions_default_l_dmax_to_yoshidas_display(name):
    default = inspect.signature(getattr(render, name)).parameters["l_dmax_cd_m2"].default
    assert default == render.L_DMAX_YOSHIDA2008_CD_M2 == 220.0
