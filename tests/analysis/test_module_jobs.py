"""One job per analysis module and no import cycle: statistics (stats) import nothing of the
analysis, effect sizes (effects) and APA formatting (apa) only the statistics; loading (load)
reaches the paradigms through their registry; and no module hides an import of another inside
a function to dodge a cycle. Read from the modules' syntax trees, so an import added anywhere,
at module level or in a function, is seen."""

import ast
from pathlib import Path

import glarelab.analysis

PACKAGE = Path(glarelab.analysis.__file__).parent
# imports made inside functions for the time they take (colour-science, statsmodels' formula
# machinery), not to dodge a cycle: the module imported there does not import the importer
LAZY = {"glarelab.analysis.stimulus_figures"}


def imports(path: Path) -> tuple[set[str], set[str]]:
    """The glarelab.analysis modules a file imports at module level and inside functions."""
    tree = ast.parse(path.read_text())
    top, inner = set(), set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            names = (
                [f"{node.module}.{a.name}" for a in node.names]
                if node.module == "glarelab.analysis"
                else [node.module]
            )
        elif isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        else:
            continue
        names = {n for n in names if n.startswith("glarelab.analysis.")}
        (top if node in tree.body else inner).update(names)
    return top, inner


def graph() -> dict[str, tuple[set[str], set[str]]]:
    modules = {
        f"glarelab.analysis.{p.stem}": imports(p)
        for p in sorted(PACKAGE.glob("*.py"))
        if p.stem != "__init__"
    }
    assert len(modules) >= 12, f"only {len(modules)} modules found under {PACKAGE}"
    return modules


def test_each_statistics_module_has_one_job():
    modules = graph()
    assert modules["glarelab.analysis.stats"][0] == set()
    assert modules["glarelab.analysis.effects"][0] == {"glarelab.analysis.stats"}
    assert modules["glarelab.analysis.apa"][0] == {"glarelab.analysis.stats"}
    assert modules["glarelab.analysis.dataset"][0] == set()


def test_no_cycle_and_no_import_hidden_in_a_function():
    modules = graph()
    for name, (_, inner) in modules.items():
        assert inner <= LAZY, f"{name} imports {inner - LAZY} inside a function"
    for lazy in LAZY:
        for name, (_, inner) in modules.items():
            if lazy in inner:
                assert name not in modules[lazy][0], f"{lazy} imports {name}: a hidden cycle"
    # depth-first search over the module-level imports
    state: dict[str, str] = {}

    def visit(name: str, path: list[str]) -> None:
        state[name] = "open"
        for target in sorted(modules.get(name, (set(), set()))[0]):
            assert state.get(target) != "open", f"import cycle: {' → '.join([*path, target])}"
            if target not in state:
                visit(target, [*path, target])
        state[name] = "done"

    for name in modules:
        if name not in state:
            visit(name, [name])


def test_loading_reaches_the_paradigms_through_their_registry():
    source = (PACKAGE / "load.py").read_text()
    assert "glarelab.analysis.paradigms" in graph()["glarelab.analysis.load"][0]
    for paradigm in ("matching", "staircase", "rating"):
        assert f'"{paradigm}"' not in source and f"'{paradigm}'" not in source, paradigm
