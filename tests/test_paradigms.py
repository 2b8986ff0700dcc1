"""Every paradigm is in every layer's registry, and nothing in the code branches on a study."""

import re
from pathlib import Path

from glarelab import protocols
from glarelab.analysis import paradigms as analysis_paradigms
from glarelab.experiments import paradigms as experiments_paradigms
from glarelab.protocols import load_protocol, shipped_protocols
from glarelab.stimuli import paradigms as stimuli_paradigms

ROOT = Path(__file__).parents[1]
PACKAGE = ROOT / "src" / "glarelab"
PAPERS = ("yoshida2008", "spencer1995", "luidolt2020")


def test_every_paradigm_is_in_every_layer():
    paradigms = set(protocols.PARADIGMS)
    assert paradigms == {"matching", "staircase", "rating"}
    assert set(stimuli_paradigms.PARADIGMS) == paradigms
    assert set(experiments_paradigms.PARADIGMS) == paradigms
    assert set(analysis_paradigms.PARADIGMS) == paradigms
    for name, entry in experiments_paradigms.PARADIGMS.items():
        assert entry.engine is not None and entry.observer is not None, name
    for name, module in analysis_paradigms.PARADIGMS.items():
        assert callable(module.analyse) and callable(module.design), name
        assert callable(module.methods), name


def test_the_papers_are_protocols_not_code():
    assert set(PAPERS) <= set(shipped_protocols())
    for paper in PAPERS:
        assert load_protocol(paper).study == paper
    # no module of the suite names a shipped study (protocol files and docs may)
    pattern = re.compile(r"[\"'](yoshida2008|spencer1995|luidolt2020)[\"']")
    for package in ("glare", "protocols", "stimuli", "experiments", "analysis"):
        paths = sorted((PACKAGE / package).rglob("*.py"))
        assert len(paths) > 5, f"no modules found under {PACKAGE / package}"
        for path in paths:
            text = "\n".join(_without_examples(path.read_text()))
            assert not pattern.search(text), f"{path.relative_to(ROOT)} names a study"


def _without_examples(text: str):
    """The lines of a module without its doctest examples (which may load a shipped study)."""
    example = False
    for line in text.splitlines():
        if line.strip().startswith(">>>"):
            example = True
        elif not line.strip():
            example = False
        if not example:
            yield line
