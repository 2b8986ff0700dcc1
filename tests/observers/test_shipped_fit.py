"""The observers the code ships are the ones docs/observers reports: the full fit's output
(docs/observers/full_fit) gives the module's constants to the digits shipped, fit.json holds
them (the Table 1 criteria and the block shift as the report found them), each report.md is
what scripts/fit_observers.py writes from its fit.json, and docs/observers.md quotes the same
numbers. Regenerate with ``python scripts/fit_observers.py --out docs/observers/full_fit``
(the fit, 2-3 minutes) and ``python scripts/fit_observers.py --no-fit --out docs/observers``."""

import importlib.util
import json
from pathlib import Path

import pytest

from glarelab.observers import brightness, noise
from glarelab.protocols import load_protocol

ROOT = Path(__file__).parents[2]
FOLDER = ROOT / "docs" / "observers"


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location(
        "fit_observers", ROOT / "scripts" / "fit_observers.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def fit() -> dict:
    return json.loads((FOLDER / "fit.json").read_text())


@pytest.fixture(scope="module")
def full_fit() -> dict:
    return json.loads((FOLDER / "full_fit" / "fit.json").read_text())


def _shipped(value: float) -> float:
    """A fitted value as the modules ship it: three significant digits."""
    return float(f"{value:.3g}")


def test_fit_json_holds_the_shipped_constants(fit):
    assert fit["theta"] == {
        "glow_gain": brightness.GLOW_GAIN,
        "glow_half": brightness.GLOW_HALF,
        "size_exponent": brightness.SIZE_EXPONENT,
        "gain_sd": noise.GAIN_SD,
        "setting_sd": noise.SETTING_SD,
        "glow_band_deg": brightness.GLOW_BAND_DEG,
    }
    criteria = {
        question: [_shipped(v) for v in pair] for question, pair in fit["criteria"].items()
    }
    assert criteria == {
        "q1_glow": [noise.GLOW_CRITERION, noise.GLOW_CRITERION_SD],
        "q2_ring": [noise.RING_CRITERION, noise.RING_CRITERION_SD],
        "q3_same_size": [noise.SIZE_TOLERANCE, noise.SIZE_TOLERANCE_SD],
    }
    assert fit["block_sd"] == noise.BLOCK_SD == noise.ObserverNoise().block_sd
    # the fit simulated the Spencer protocol as it is shipped
    protocol = load_protocol("spencer1995")
    assert fit["spencer"]["strengths"] == protocol["glare"]["strengths"]
    assert fit["spencer"]["contexts"] == [c["name"] for c in protocol["contexts"]]


def test_the_full_fit_gives_the_shipped_constants(fit, full_fit):
    shipped = {k: _shipped(v) for k, v in full_fit["theta"].items()}
    assert shipped == fit["theta"]
    for question, pair in full_fit["criteria"].items():
        assert [_shipped(v) for v in pair] == [_shipped(v) for v in fit["criteria"][question]]
    assert full_fit["block_sd"] == noise.BLOCK_SD
    assert full_fit["fit"]["bands"][f"{brightness.GLOW_BAND_DEG:.2f}"] == full_fit["fit"]["loss"]
    assert full_fit["spencer"]["strengths"] == fit["spencer"]["strengths"]


@pytest.mark.parametrize("folder", [FOLDER, FOLDER / "full_fit"], ids=["no_fit", "full_fit"])
def test_report_md_is_what_the_script_writes_from_fit_json(script, folder):
    protocol = load_protocol("yoshida2008")
    labels = {m["name"]: m["labels"] for m in protocol["glare"]["methods"]}
    summary = json.loads((folder / "fit.json").read_text())
    assert (folder / "report.md").read_text() == script.markdown(summary, {"labels": labels})


def test_docs_quote_the_fit(fit, full_fit):
    text = (ROOT / "docs" / "observers.md").read_text()
    bands = full_fit["fit"]["bands"]
    best = f"{brightness.GLOW_BAND_DEG:.2f}"
    misfits = [f"**{v:.2f}**" if b == best else f"{v:.2f}" for b, v in bands.items()]
    assert "| misfit | " + " | ".join(misfits) + " |" in text
    spencer = fit["spencer"]
    rates = spencer["context_significant_rate_by_block_sd"]
    quoted = [
        f"| `σ_b` block shift | {noise.BLOCK_SD:g} |",
        f"significant in {100 * spencer['context_significant_rate']:.0f} % of "
        f"{spencer['studies']} studies with `σ_b` = {fit['block_sd']:g}",
        "as " + ", ".join(f"{100 * r:.0f}" for r in rates.values()) + " %",
        f"F(1, 6) median {spencer['context_F']['median']:.1f} "
        f"[{spencer['context_F']['p10']:.1f}, {spencer['context_F']['p90']:.1f}]",
    ]
    for line in quoted:
        assert line in text, line
