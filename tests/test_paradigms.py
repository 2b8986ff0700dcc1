"""Every paradigm is in every layer's registry, and nothing in the code branches on a study."""

import ast
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


PARADIGM_NAMES = {"matching", "staircase", "rating"}
# a paradigm's own modules, one per layer, and the registries that list them
OWN = {"matching.py", "staircase.py", "rating.py", "night.py", "paradigms.py"}


def _names_a_paradigm(node: ast.AST) -> bool:
    if isinstance(node, ast.Constant):
        return node.value in PARADIGM_NAMES
    if isinstance(node, ast.Tuple | ast.List | ast.Set):
        return any(_names_a_paradigm(e) for e in node.elts)
    return False


def branches_on_a_paradigm(source: str) -> list[int]:
    """Lines comparing a value with a paradigm's name (``x == "matching"``, ``x in
    ("matching", "staircase")``)."""
    return [
        node.lineno
        for node in ast.walk(ast.parse(source))
        if isinstance(node, ast.Compare)
        and any(_names_a_paradigm(part) for part in [node.left, *node.comparators])
    ]


def test_nothing_outside_a_paradigms_modules_branches_on_its_name():
    paths = [p for p in sorted(PACKAGE.rglob("*.py")) if p.name not in OWN]
    assert len(paths) > 100, f"too few modules under {PACKAGE}"
    found = [
        f"{path.relative_to(ROOT)}:{line}"
        for path in paths
        for line in branches_on_a_paradigm(path.read_text(encoding="utf-8"))
    ]
    assert found == []


def test_the_branch_scan_sees_a_branch():
    assert branches_on_a_paradigm('if paradigm == "matching":\n    pass\n') == [1]
    assert branches_on_a_paradigm('ok = p not in ("matching", "staircase")\n') == [1]
    assert branches_on_a_paradigm('x = {"rating": 1}\n') == []


def test_each_contract_names_the_order_fields_its_engine_records():
    """A session writes ``counterbalance`` from an engine that orders its blocks by it and
    ``trial_order`` from an engine's ``order``; the contract's ``SESSION_ORDER`` (what the
    analysis admits in a sidecar) names exactly those."""
    for name, contract in protocols.PARADIGMS.items():
        engine = experiments_paradigms.PARADIGMS[name].engine
        recorded = {
            "counterbalance": engine.counterbalanced,
            "trial_order": isinstance(getattr(engine, "order", None), property),
        }
        assert set(contract.SESSION_ORDER) == {k for k, v in recorded.items() if v}, name
        assert protocols.core.session_order(name) == contract.SESSION_ORDER
