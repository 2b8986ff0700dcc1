"""The power and effect-size figures as printed: each panel's legend outside its plot (never
over the lowest curve), and no text below 8 pt at a page's width."""

from __future__ import annotations

from unittest import mock

import matplotlib.text
import pandas as pd
import pytest

from glarelab.analysis import figures
from glarelab.planning.power import effect_size_figure, power_figure


def _power() -> pd.DataFrame:
    rows = []
    for analysis in ("6 × 2 (all levels)", "3 × 2 (low)", "boost"):
        for index, effect in enumerate(("L_disk", "method", "L_disk × method")):
            for n in (6, 10, 14, 20):
                p = min(1.0, 0.05 + 0.03 * n * (index + 1))
                rows.append(
                    {"effect": f"{analysis}: {effect}", "participants": n, "power": p,
                     "ci_low": max(0.0, p - 0.05), "ci_high": min(1.0, p + 0.05),
                     "replications": 200, "size": "η²p", "q05": 0.1, "q25": 0.2, "q50": 0.3,
                     "q75": 0.4, "q95": 0.5}
                )  # fmt: skip
    return pd.DataFrame(rows)


@pytest.mark.parametrize("draw", ["power", "effect sizes"])
def test_legends_stay_off_the_curves_and_text_prints_at_8_pt(draw):
    drawn = []
    real = figures.png

    def keep(figure):  # as png() draws it
        figures.legible(figure)
        figure.tight_layout()
        figure.draw_without_rendering()
        drawn.append(figure)
        scale = figures.printed_scale(figure)
        texts = [
            t for t in figure.findobj(matplotlib.text.Text) if t.get_text() and t.get_visible()
        ]
        assert min(t.get_fontsize() for t in texts) * scale >= figures.MIN_PRINTED_PT - 1e-9
        for axis in figure.axes:
            legend = axis.get_legend()
            if legend is None or not axis.get_visible() or not axis.axison:
                continue
            box = legend.get_window_extent()
            assert not box.overlaps(axis.get_window_extent()), axis.get_title()
        return real(figure)

    with mock.patch.object(figures, "png", keep):
        if draw == "power":
            power_figure(_power(), target=0.8, alpha=0.05, title="yoshida2008")
        else:
            effect_size_figure(_power(), title="yoshida2008")
    assert drawn
