"""The layers import only what is below them, and only the front-end imports PsychoPy.

Every import of every module is read from its syntax tree, whether at module level or inside a
function (a function-level import is a dependency too, only a later one). :data:`ALLOWED` lists
the layers, lowest first, and what each may import of the suite; docs/extending.md says why the
cut is where it is. Each rule is also broken on purpose below, to show the test sees it.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "glarelab"

# the layers of glarelab and the layers each may import (besides itself)
ALLOWED: dict[str, set[str]] = {
    "files": set(),
    "glare": {"files"},
    "protocols": {"files", "glare"},
    "display": {"files", "protocols"},
    "stimuli": {"files", "glare", "protocols", "display"},
    "observers": {"files", "glare", "protocols", "display", "stimuli"},
    "experiments": {"files", "glare", "protocols", "display", "stimuli", "observers"},
    "frontend": {"files", "glare", "protocols", "display", "stimuli", "observers", "experiments"},
    "analysis": {"files", "glare", "protocols", "display", "stimuli"},
    "planning": {
        "files",
        "glare",
        "protocols",
        "display",
        "stimuli",
        "observers",
        "experiments",
        "analysis",
    },
    "bench": {"files", "glare", "protocols", "display", "stimuli", "analysis"},
    # the command line and the tools that drive whole studies may use every layer
    "cli": {
        "files",
        "glare",
        "protocols",
        "display",
        "stimuli",
        "observers",
        "experiments",
        "frontend",
        "analysis",
        "planning",
        "bench",
        "cli",
    },
}
# modules at the package's top level and the layer they belong to
TOP_LEVEL = {
    "__init__": "cli",
    "__main__": "cli",
    "cli": "cli",
    "commands": "cli",
    "demo": "cli",
    "docs": "cli",
    "bench": "bench",
}
# libraries only the front-end may import: the window, its events and its hardware
FRONTEND_ONLY = {"psychopy", "pyglet", "psychtoolbox"}
# pairs of layers that may import each other: none (the observers know no engine or session;
# each paradigm's simulated participant in experiments uses them)
MUTUAL: set[tuple[str, str]] = set()


def layer_of(module: str) -> str | None:
    """``glarelab.stimuli.exr`` → ``stimuli``; None outside glarelab."""
    parts = module.split(".")
    if parts[0] != "glarelab":
        return None
    if len(parts) == 1:
        return "cli"
    return TOP_LEVEL.get(parts[1], parts[1])


def imports(module: str, source: str, *, is_package: bool = False):
    """(line, imported module) of every import in ``source``, the module ``module``."""
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = module.split(".")
                base = base[: len(base) - node.level + (1 if is_package else 0)]
                name = ".".join([*base, node.module] if node.module else base)
            else:
                name = node.module or ""
            yield node.lineno, name
            for alias in node.names:  # `from glarelab import experiments` imports a layer
                if name == "glarelab":
                    yield node.lineno, f"glarelab.{alias.name}"


def violations(module: str, source: str, *, is_package: bool = False) -> list[str]:
    """The imports of ``module`` that break the rules, one line each."""
    found = []
    layer = layer_of(module)
    if layer not in ALLOWED:
        return [f"{module}: in no layer ({layer!r}); add it to ALLOWED"]
    for line, name in imports(module, source, is_package=is_package):
        top = name.split(".")[0]
        if top in FRONTEND_ONLY and layer not in ("frontend",):
            found.append(f"{module}:{line} imports {name}: only glarelab.frontend imports {top}")
            continue
        target = layer_of(name)
        if name == "glarelab" or target is None or target == layer or target in ALLOWED[layer]:
            continue
        if (layer, target) in MUTUAL or (target, layer) in MUTUAL:
            continue
        found.append(f"{module}:{line} imports {name}: {layer} may not import {target}")
    return found


def modules():
    paths = sorted(PACKAGE.rglob("*.py"))
    for path in paths:
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts = parts[:-1]
        yield ".".join(parts), path, is_package


def test_the_scan_finds_every_layer():
    found = {layer_of(name) for name, _, _ in modules()}
    assert len(list(modules())) > 100, f"too few modules under {PACKAGE}"
    assert {"files", "glare", "protocols", "display", "stimuli", "observers", "experiments",
            "frontend", "analysis", "planning", "bench", "cli"} <= found  # fmt: skip


def test_no_module_imports_above_its_layer():
    found = []
    for name, path, is_package in modules():
        found += violations(name, path.read_text(encoding="utf-8"), is_package=is_package)
    assert found == []


@pytest.mark.parametrize(
    ("module", "line"),
    [
        ("glarelab.analysis.load", "from glarelab.experiments.data import session_files"),
        ("glarelab.analysis.load", "import glarelab.experiments.data"),
        ("glarelab.analysis.load", "from glarelab import experiments"),
        ("glarelab.analysis.report", "from ..experiments import data"),
        ("glarelab.glare.models.cache", "from glarelab.stimuli import exr"),
        ("glarelab.glare.models.cache", "from glarelab.protocols import load_protocol"),
        ("glarelab.experiments.session", "from psychopy import visual"),
        ("glarelab.stimuli.night", "import pyglet"),
        ("glarelab.glare.night.live", "from psychopy import core"),
        ("glarelab.glare.night.live", "from glarelab.stimuli.night import night_street"),
        ("glarelab.files.atomic", "from glarelab.glare import render_glare"),
        ("glarelab.planning.power", "from glarelab.frontend.session import PsychoPyFrontend"),
        ("glarelab.experiments.loop", "from glarelab.analysis import load"),
        ("glarelab.observers.noise", "from glarelab.experiments.engine import participant_rng"),
        ("glarelab.analysis.report", "from glarelab.observers import BrightnessModel"),
    ],
)
def test_each_rule_catches_its_break(module, line):
    # the forbidden import inside a function counts as much as one at module level
    for source in (line + "\n", f"def f():\n    {line}\n"):
        assert violations(module, source), f"{line!r} in {module} was not caught"


def test_allowed_imports_pass():
    assert (
        violations("glarelab.analysis.report", "from glarelab.files.atomic import write_text\n")
        == []
    )
    assert violations("glarelab.frontend.window", "from psychopy import visual\n") == []
    assert violations("glarelab.glare.models.cache", "from glarelab.files import atomic\n") == []
    assert violations("glarelab.stimuli", "from .exr import read_exr\n", is_package=True) == []
