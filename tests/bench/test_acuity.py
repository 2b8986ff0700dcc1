"""glarelab bench --acuity: every way of the acuity blur against the exact one."""

from glarelab.bench.acuity import acuity_bench, acuity_table
from glarelab.glare.night.acuity import LEVELS_PER_OCTAVE


def test_acuity_bench_measures_every_way_against_the_exact_blur():
    rows = acuity_bench(repeats=1, only=("street_0.0297deg",), log=lambda line: None)
    errors = {r["variant"]: r["max_codes"] for r in rows}
    assert errors["exact"] == 0.0
    ladder = [errors[f"layers, {n}/octave"] for n in (1, 2, 4, 8, 16)]
    assert ladder == sorted(ladder, reverse=True)  # more levels, less error
    # the default (glarelab.glare.night.acuity.LEVELS_PER_OCTAVE) keeps within half a code
    assert errors[f"layers, {LEVELS_PER_OCTAVE}/octave"] < 0.5
    assert errors["uniform σ (gaussian_filter)"] > 10  # ignoring the variation is visible
    assert "| street_0.0297deg |" in acuity_table(rows)
