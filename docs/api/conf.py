"""Sphinx configuration of glarelab's API reference, built from the numpydoc docstrings.

Build (nitpicky: a dead cross-reference fails the build)::

    python -m sphinx -b html -n -W --keep-going -j auto docs/api out/api

``make docs-api`` runs this; ``make test`` runs it first.
"""

from __future__ import annotations

import ast
import builtins
import importlib
import inspect
import sys
from pathlib import Path

from sphinx.ext.autodoc.mock import mock

# The docs describe the tree they are in, whatever glarelab is installed.
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "src"))

project = "glarelab"
author = "glarelab"
extensions = ["sphinx.ext.autodoc", "sphinx.ext.autosummary", "numpydoc"]
templates_path = ["_templates"]
exclude_patterns = ["_build"]
root_doc = "index"

# One page per package and per public module, generated from the code on every build (into
# docs/api/generated/, not kept in git): a new module is documented without editing a page.
autosummary_generate = True
autosummary_generate_overwrite = True
autosummary_imported_members = False
# Each object is documented once, in the module that defines it (``ignore-module-all``: a
# package's ``__all__`` re-exports are not documented twice); a reference by its public path
# (``glarelab.glare.render_glare``) resolves to that definition, see ``_resolve_alias``.
autodoc_default_options = {
    "members": True,
    "undoc-members": True,
    "ignore-module-all": True,
    "no-value": True,
    "member-order": "bysource",
}
# PsychoPy is imported by the front-end only, and opens a window system when it is: the
# reference is built without a screen (and PsychoPy's visual module crashes when imported after
# autodoc), so autodoc reads the front-end against stand-ins for it
autodoc_mock_imports = ["psychopy", "pyglet"]
# for the whole build, not only while autodoc imports a module: Sphinx's source analyser
# imports the module an inherited member comes from (psychopy.visual) on its own
_mocked = mock(autodoc_mock_imports)
_mocked.__enter__()
autodoc_typehints = "signature"
autodoc_preserve_defaults = True
autodoc_inherit_docstrings = False  # a method overriding the standard library's has its own


def _spec(module: str):
    """The import spec of a module, or None when no module has that name."""
    try:
        return importlib.util.find_spec(module)
    except (ImportError, ValueError):
        return None


def _constants(module: str) -> list[tuple[str, bool]]:
    """The public names a module assigns at its top level, and whether to show each value.

    autodoc documents a module's data only when it has a ``#:`` comment (it cannot tell a
    constant defined in the module from one imported into it); the source can.
    """
    spec = _spec(module)
    if spec is None or spec.origin is None or not spec.origin.endswith(".py"):
        return []
    tree = ast.parse(Path(spec.origin).read_text(encoding="utf-8"))
    names: dict[str, None] = {}
    for statement in tree.body:
        targets = (
            statement.targets
            if isinstance(statement, ast.Assign)
            else [statement.target]
            if isinstance(statement, ast.AnnAssign) and statement.value is not None
            else []
        )
        for target in targets:
            if isinstance(target, ast.Name) and not target.id.startswith("_"):
                names[target.id] = None
    defined = {
        statement.name
        for statement in tree.body
        if isinstance(statement, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef)
    }
    objects = importlib.import_module(module)
    shown = []
    for name in names:
        if name in defined or name == "__all__" or not hasattr(objects, name):
            continue
        value = getattr(objects, name)
        if isinstance(value, type(sys)) or inspect.isroutine(value):
            continue
        shown.append((name, len(repr(value)) <= 80))
    return shown


autosummary_context = {"constants": _constants}

# numpydoc renders the Parameters/Returns/... sections; the types written in them stay text
# (numpydoc_xref_param_type off), the cross-references in the prose are checked.
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# numpydoc's References sections are listed without in-text citation marks.
# autosummary_context holds a function (the constants of a module), which Sphinx cannot pickle
# for an incremental rebuild; every build here is a fresh one.
suppress_warnings = ["ref.citation", "config.cache"]

# Nitpicky, but only for glarelab's own names: the build is offline (no intersphinx), so a
# reference to the standard library, numpy, pandas and the other dependencies cannot resolve.
nitpicky = True
_EXTERNAL = (
    "numpy|np|numpy.typing|pandas|pd|scipy|matplotlib|distributed|dask|colour|psychopy|"
    "statsmodels|PIL|png|serial|threadpoolctl|platformdirs|OpenEXR|Imath|cv2|pingouin|"
    "pathlib|collections|typing|types|os|io|argparse|subprocess|concurrent|multiprocessing|"
    "enum|dataclasses|datetime|logging|tomllib|numbers|contextlib|functools|threading|json|csv|"
    "zipfile|tempfile|random|math|re|abc|signal|socket|queue|weakref|builtins|_io|"
    "_thread|mmap|fractions|decimal|itertools|shutil|sys|time|warnings|hashlib|uuid"
)
_BUILTIN = (
    "None|int|float|str|bytes|bool|complex|object|type|list|tuple|dict|set|frozenset|slice|"
    "range|callable|Ellipsis|NotImplemented|Any|Callable|Iterable|Iterator|Sequence|Mapping|"
    "Literal|Self|Path|ndarray|DataFrame|Series|NDArray|ArrayLike|"
    r"[A-Za-z]*(Error|Exception|Warning)|KeyboardInterrupt|SystemExit|GeneratorExit"
)
nitpick_ignore_regex = [
    (r"py:.*", rf"({_EXTERNAL})(\..*)?"),
    (r"py:.*", rf"({_BUILTIN})"),
    (r"py:.*", "|".join(name for name in dir(builtins) if not name.startswith("_"))),
]


def _lookup(path: str):
    """The object a dotted path names by import and attribute access, or None."""
    parts = path.split(".")
    for split in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:split]))
        except ImportError:  # also ModuleNotFoundError: a name inside a module, not a module
            continue
        for name in parts[split:]:
            obj = getattr(obj, name, None)
            if obj is None:
                return None
        return obj
    return None


def _imported_from(path: str) -> str | None:
    """``A.name`` when the module of ``path`` (``M.name``) has ``from A import name``."""
    module, _, name = path.rpartition(".")
    spec = _spec(module) if module.startswith("glarelab") else None
    if spec is None or spec.origin is None or not spec.origin.endswith(".py"):
        return None
    for statement in ast.walk(ast.parse(Path(spec.origin).read_text(encoding="utf-8"))):
        if isinstance(statement, ast.ImportFrom) and statement.level == 0 and statement.module:
            for alias in statement.names:
                if (alias.asname or alias.name) == name:
                    return f"{statement.module}.{alias.name}"
    return None


def _defined_at(path: str) -> list[str]:
    """Where autodoc may document the object ``path`` names (its definition), best first.

    A class, function or module by its own ``__module__`` and ``__qualname__``; an attribute
    of a class under the class's definition; a constant by following the ``from ... import``
    lines that bring it where the path names it.
    """
    obj = _lookup(path)
    if obj is None:
        return []
    if isinstance(obj, type(sys)):
        return [obj.__name__]
    module, qualname = getattr(obj, "__module__", None), getattr(obj, "__qualname__", None)
    if isinstance(module, str) and isinstance(qualname, str) and module.startswith("glarelab"):
        return [f"{module}.{qualname}"]
    parent, _, name = path.rpartition(".")
    if isinstance(_lookup(parent), type):
        return [f"{where}.{name}" for where in _defined_at(parent)]
    found = []
    while (path := _imported_from(path)) is not None and path not in found:
        found.append(path)
    return found


def _resolve_alias(app, env, node, contnode):
    """Resolve a glarelab name that is imported where the reference names it.

    A reference to ``glarelab.glare.render_glare`` (the public path) or to ``render_glare``
    inside :mod:`glarelab.glare` names a function documented at its definition,
    ``glarelab.glare.rendering.render.render_glare``: the name is looked up by import, and the
    reference resolves only when the object it names is documented. Anything else stays a dead
    reference, which the nitpicky build reports.
    """
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip("~.")
    context = [node.get("py:module"), node.get("py:class")]
    candidates = [target]
    row = node.parent
    while row is not None and row.tagname != "row":
        row = row.parent
    if row is not None:  # a module's summary line in its package's table: the module's names
        name = row[0].next_node(lambda n: n.tagname in ("pending_xref", "reference"))
        module = name and (name.get("reftarget") or name.get("reftitle"))
        if module:
            candidates.append(f"{module}.{target}")
    if context[0]:
        if context[1]:
            candidates.append(f"{context[0]}.{context[1]}.{target}")
        candidates.append(f"{context[0]}.{target}")
    domain = env.get_domain("py")
    for candidate in candidates:
        if not candidate.startswith("glarelab"):
            continue
        if any(part.startswith("_") for part in candidate.split(".")) and _lookup(candidate):
            return contnode  # a private name that exists: shown as text, not in the reference
        for where in dict.fromkeys([candidate, *_defined_at(candidate)]):
            alias = node.deepcopy()
            alias["reftarget"] = where
            alias["refspecific"] = False
            for role in ("obj", node["reftype"]):
                found = domain.resolve_xref(
                    env, node["refdoc"], app.builder, role, where, alias, contnode
                )
                if found is not None:
                    return found
    return None


def _no_type_docstring(app, what, name, obj, options, lines):
    """A constant without a ``#:`` comment shows no docstring (not its type's, numpy's)."""
    own = inspect.getdoc(type(obj)) or ""
    if what == "data" and lines and "\n".join(lines).strip() == own.strip():
        lines.clear()


def _factory_default(app, what, name, obj, options, signature, return_annotation):
    """A dataclass field's ``default_factory`` shows as ``...``: ``<factory>`` is no Python."""
    if signature and "<factory>" in signature:
        return signature.replace("<factory>", "..."), return_annotation
    return None


def setup(app):
    app.connect("missing-reference", _resolve_alias)
    app.connect("autodoc-process-docstring", _no_type_docstring, priority=1)
    app.connect("autodoc-process-signature", _factory_default)
