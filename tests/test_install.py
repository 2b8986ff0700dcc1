"""glarelab installs as one package and runs beside a lab's own code of the same names."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import sysconfig
import textwrap
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
OLD_TOP_LEVEL = {"glare", "stimuli", "experiments", "analysis", "protocols", "planning"}
SOURCES = ["glarelab", "glare", "stimuli", "experiments", "analysis", "protocols", "planning"]


def _imports(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.lineno, node.module


def _embedded_scripts(tree: ast.AST):
    """Strings that parse as Python with an import in them: scripts a test runs apart."""
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Constant)
            and isinstance(node.value, str)
            and "import" in node.value
        ):
            try:
                yield node.lineno, ast.parse(textwrap.dedent(node.value))
            except SyntaxError:
                continue


def test_no_module_imports_a_top_level_name_the_wheel_does_not_install():
    # only `glarelab` is installed: `import stimuli` would find a lab's stimuli.py instead,
    # and a test's script run with the repository on its path would import a second copy
    found = []
    for folder in [*SOURCES, "tests", "scripts"]:
        for path in sorted((ROOT / folder).rglob("*.py")):
            tree = ast.parse(path.read_text(), str(path))
            trees = [(0, tree), *_embedded_scripts(tree)]
            for offset, part in trees:
                for lineno, name in _imports(part):
                    if name.split(".")[0] in OLD_TOP_LEVEL:
                        where = f"{path.relative_to(ROOT)}:{offset + lineno if offset else lineno}"
                        found.append(f"{where}: import of {name}")
    assert found == []


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """A fresh virtual environment with the built wheel and nothing else of glarelab."""
    tmp = tmp_path_factory.mktemp("wheel")
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(tmp), str(ROOT)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert build.returncode == 0, build.stderr[-2000:]
    (wheel,) = tmp.glob("glarelab-*.whl")
    env_dir = tmp / "venv"
    venv.create(env_dir, with_pip=True)
    python = env_dir / "bin" / "python"
    # the dependencies come from this interpreter's site-packages, as a plain path entry: a
    # .pth line adds the folder but not the editable install's finder that lives there
    purelib = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    ours = [p for p in sys.path if p.endswith("site-packages")] or [
        sysconfig.get_paths()["purelib"]
    ]
    Path(purelib, "dependencies.pth").write_text("".join(p + "\n" for p in ours))
    install = subprocess.run(
        [str(python), "-m", "pip", "install", "--no-deps", "--quiet", str(wheel)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert install.returncode == 0, install.stderr[-2000:]
    return env_dir


def _lab_folder(path: Path) -> Path:
    """A lab's project folder with modules named as ours were, each of which fails loudly."""
    path.mkdir()
    boom = "raise SystemExit('the lab\\'s own {} was imported')\n"
    for name in ("analysis.py", "stimuli.py", "glare.py", "protocols.py", "planning.py"):
        (path / name).write_text(boom.format(name))
    (path / "experiments").mkdir()
    (path / "experiments" / "__init__.py").write_text(boom.format("experiments/"))
    return path


def test_the_wheel_holds_one_top_level_package(installed):
    python = installed / "bin" / "python"
    listing = subprocess.run(
        [
            str(python),
            "-c",
            "import importlib.metadata as m; "
            "print('\\n'.join(sorted({str(f).split('/')[0] for f in m.files('glarelab')})))",
        ],
        cwd=installed,  # not the repository, whose egg-info would answer
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    # RECORD also lists the console script, as ../../../bin/glarelab
    top = [n for n in listing if not n.endswith((".dist-info", ".data")) and n != ".."]
    assert top == ["glarelab"]


def test_glarelab_runs_from_a_folder_holding_a_labs_analysis_py(installed, tmp_path):
    lab = _lab_folder(tmp_path / "lab")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    version = subprocess.run(
        [str(installed / "bin" / "python"), "-m", "glarelab", "--version"],
        cwd=lab,
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert version.returncode == 0, version.stderr
    assert version.stdout.startswith("glarelab ")
    demo = subprocess.run(
        [str(installed / "bin" / "python"), "-m", "glarelab", "demo", "--out", "out/demo"],
        cwd=lab,
        capture_output=True,
        text=True,
        env=env,
        timeout=900,
    )
    assert demo.returncode == 0, demo.stderr[-3000:]
    assert (lab / "out" / "demo" / "report" / "report.html").is_file()
