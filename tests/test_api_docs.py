"""The API reference: every package is in it, and every public callable documents its parameters.

The reference itself is built by ``make docs-api`` (Sphinx, nitpicky: a dead cross-reference
fails it), which ``make test`` runs before the test suite; these tests read the sources only,
so they take a second.

A *public callable* is a function or class that a public module (no part of its dotted name
starts with ``_``) exports, that is, names in its ``__all__``, or without ``__all__`` defines
at its top level under a name without a leading underscore; and the public methods of those
classes. Its parameters are its arguments but ``self`` and ``cls``; a class's are those of its
``__init__`` or, for a dataclass, its fields. Each must be named in the numpydoc
``Parameters`` (or ``Other Parameters``) section of its docstring, with a description; a
class documents them in its own docstring (numpydoc's convention) or its ``__init__``'s, a
dataclass its fields in ``Parameters`` or ``Attributes``.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import pytest
from numpydoc.docscrape import NumpyDocString

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "glarelab"
INDEX = ROOT / "docs" / "api" / "index.rst"


@dataclass(frozen=True)
class Callable:
    module: str
    qualname: str
    params: tuple[str, ...]
    docstrings: tuple[str, ...]  # a class's own and its __init__'s
    fields: bool = False  # a dataclass's fields: its Attributes section may name them

    @property
    def package(self) -> str:
        return self.module.split(".")[1] if "." in self.module else self.module

    def __str__(self) -> str:
        return f"{self.module}.{self.qualname}"


def public_modules() -> list[tuple[str, Path]]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if any(part.startswith("_") for part in parts):
            continue
        found.append((".".join(parts), path))
    return found


def _exported(tree: ast.Module) -> set[str] | None:
    for statement in tree.body:
        if isinstance(statement, ast.Assign | ast.AnnAssign):
            targets = (
                statement.targets if isinstance(statement, ast.Assign) else [statement.target]
            )
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                try:
                    return set(ast.literal_eval(statement.value))
                except ValueError:
                    return None  # computed: fall back to the names' underscores
    return None


def _arguments(function: ast.FunctionDef | ast.AsyncFunctionDef) -> list[str]:
    args = function.args
    names = [a.arg for a in (*args.posonlyargs, *args.args, *args.kwonlyargs)]
    if args.vararg:
        names.append(args.vararg.arg)
    if args.kwarg:
        names.append(args.kwarg.arg)
    return [name for name in names if name not in ("self", "cls")]


def _is_dataclass(cls: ast.ClassDef) -> bool:
    for decorator in cls.decorator_list:
        target = decorator.func if isinstance(decorator, ast.Call) else decorator
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name == "dataclass":
            return True
    return False


def _fields(cls: ast.ClassDef) -> list[str]:
    fields = []
    for statement in cls.body:
        if isinstance(statement, ast.AnnAssign) and isinstance(statement.target, ast.Name):
            annotation = ast.unparse(statement.annotation)
            if "ClassVar" in annotation or statement.target.id.startswith("_"):
                continue
            value = statement.value
            if (
                isinstance(value, ast.Call)
                and ast.unparse(value.func).endswith("field")
                and any(
                    k.arg == "init" and ast.unparse(k.value) == "False" for k in value.keywords
                )
            ):
                continue
            fields.append(statement.target.id)
    return fields


def _is_property(function: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    return any(
        ast.unparse(d) in ("property", "cached_property", "functools.cached_property")
        or ast.unparse(d).endswith((".setter", ".deleter"))
        for d in function.decorator_list
    )


def _present(docstrings: list[str | None]) -> tuple[str, ...]:
    return tuple(d for d in docstrings if d)


def public_callables() -> list[Callable]:
    found = []
    for module, path in public_modules():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        exported = _exported(tree)
        for node in tree.body:
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                continue
            if exported is not None and node.name not in exported:
                continue
            if exported is None and node.name.startswith("_"):
                continue
            if isinstance(node, ast.ClassDef):
                methods = {
                    m.name: m
                    for m in node.body
                    if isinstance(m, ast.FunctionDef | ast.AsyncFunctionDef)
                }
                if _is_dataclass(node) and "__init__" not in methods:
                    params = _fields(node)
                else:
                    params = _arguments(methods["__init__"]) if "__init__" in methods else []
                docstrings = [ast.get_docstring(node)]
                if "__init__" in methods:
                    docstrings.append(ast.get_docstring(methods["__init__"]))
                fields = _is_dataclass(node) and "__init__" not in methods
                found.append(
                    Callable(module, node.name, tuple(params), _present(docstrings), fields)
                )
                for name, method in methods.items():
                    if name.startswith("_") or _is_property(method):
                        continue
                    found.append(
                        Callable(
                            module,
                            f"{node.name}.{name}",
                            tuple(_arguments(method)),
                            _present([ast.get_docstring(method)]),
                        )
                    )
            else:
                found.append(
                    Callable(
                        module,
                        node.name,
                        tuple(_arguments(node)),
                        _present([ast.get_docstring(node)]),
                    )
                )
    return found


def _documented(docstrings: tuple[str, ...], *, fields: bool = False) -> dict[str, str]:
    """The parameters numpydoc docstrings name, each with its description (a dataclass's
    fields: in its Parameters or its Attributes section)."""
    documented: dict[str, str] = {}
    for docstring in docstrings:
        try:
            parsed = NumpyDocString(docstring)
        except Exception as error:  # numpydoc raises ValueError and its own ParseError
            raise AssertionError(f"numpydoc cannot read the docstring: {error}") from error
        sections = ["Parameters", "Other Parameters"] + (["Attributes"] if fields else [])
        for section in sections:
            for parameter in parsed[section]:
                for name in parameter.name.split(","):
                    documented[name.strip().lstrip("*")] = " ".join(parameter.desc).strip()
    return documented


def undocumented(callable_: Callable) -> list[str]:
    """The parameters of a callable its docstring does not name or leaves undescribed."""
    if not callable_.params:
        return []
    documented = _documented(callable_.docstrings, fields=callable_.fields)
    return [p for p in callable_.params if not documented.get(p)]


CALLABLES = public_callables()
WITH_PARAMETERS = [c for c in CALLABLES if c.params]
# every subpackage and top-level module of glarelab: the test is exact for each
PACKAGES = sorted({name.split(".")[1] for name, _ in public_modules() if "." in name})


def test_the_scan_finds_the_public_callables():
    packages = {c.package for c in CALLABLES}
    assert {"glare", "stimuli", "experiments", "analysis", "protocols", "files"} <= packages
    assert {"glare", "frontend", "cli"} <= set(PACKAGES)
    assert len(WITH_PARAMETERS) > 300
    names = {str(c) for c in CALLABLES}
    assert "glarelab.glare.rendering.render.render_glare" in names
    assert "glarelab.files.locks.ProcessLock" in names


@pytest.mark.parametrize("package", PACKAGES)
def test_every_parameter_is_documented(package):
    missing = {
        str(c): undocumented(c)
        for c in WITH_PARAMETERS
        if c.package == package and undocumented(c)
    }
    assert not missing, f"public callables of glarelab.{package} without their parameters " + (
        "documented (numpydoc Parameters section):\n"
        + "\n".join(f"  {name}: {', '.join(params)}" for name, params in missing.items())
    )


def test_a_missing_parameter_is_found():
    def callable_(docstring):
        return Callable("glarelab.x", "f", ("pixel_deg", "seed"), _present([docstring]))

    complete = (
        "Do.\n\nParameters\n----------\npixel_deg : float\n    Degrees.\nseed : int\n    Seed.\n"
    )
    assert undocumented(callable_(complete)) == []
    assert undocumented(callable_(complete.replace("seed : int\n    Seed.\n", ""))) == ["seed"]
    assert undocumented(callable_("Do.")) == ["pixel_deg", "seed"]
    assert undocumented(callable_(None)) == ["pixel_deg", "seed"]
    grouped = "Do.\n\nParameters\n----------\npixel_deg, seed\n    Both.\n"
    assert undocumented(callable_(grouped)) == []
    fields = (
        "Do.\n\nAttributes\n----------\npixel_deg : float\n    Degrees.\nseed : int\n    Seed.\n"
    )
    assert undocumented(callable_(fields)) == ["pixel_deg", "seed"]
    dataclass_ = Callable("glarelab.x", "C", ("pixel_deg", "seed"), (fields,), fields=True)
    assert undocumented(dataclass_) == []
    empty = "Do.\n\nParameters\n----------\npixel_deg\nseed\n    Seed.\n"
    assert undocumented(callable_(empty)) == ["pixel_deg"]


def test_every_package_has_a_page():
    listed = set(re.findall(r"^\s+(glarelab\.\w+)\s*$", INDEX.read_text(), re.MULTILINE))
    top = {name for name, _ in public_modules() if name.count(".") == 1}
    assert top - listed == set(), "add these to docs/api/index.rst"
    assert listed - top == set(), "these are no longer modules of glarelab"
