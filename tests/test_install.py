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
SOURCES = ["src"]


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


# --- a plain `pip install .` serves every tool run in the clone ---------------------------------


def _in_clone(installed, *args, timeout=600, input=None):
    """Run the installed venv's Python in the repository, as a user of a clone does."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run(
        [str(installed / "bin" / "python"), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout,
        input=input,
    )


def _readme_python() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    start = text.index("```python\n") + len("```python\n")
    return text[start : text.index("```", start)]


def test_the_readme_python_example_runs_in_the_clone(installed):
    inputs = (
        "import numpy as np\n"
        "image = np.full((1080, 1920), 20.0)\n"
        "image[530:550, 950:970] = 5000.0\n"
        "luminance_cd_m2 = image\n"
        "frames = [image]\n"
    )
    done = _in_clone(installed, "-", input=inputs + _readme_python() + "\nprint(glare.__file__)\n")
    assert done.returncode == 0, done.stderr[-3000:]
    # the installed copy, not the clone's source
    assert str(ROOT / "src") not in done.stdout.splitlines()[-1]
    assert "site-packages" in done.stdout.splitlines()[-1]


def test_the_module_and_the_scripts_run_in_the_clone(installed, tmp_path):
    version = _in_clone(installed, "-m", "glarelab", "--version")
    assert version.returncode == 0, version.stderr
    assert version.stdout.startswith("glarelab ")
    seeds = _in_clone(installed, "scripts/yoshida_seeds.py", "--help")
    assert seeds.returncode == 0, seeds.stderr[-2000:]
    fit = _in_clone(
        installed,
        "scripts/fit_observers.py",
        "--no-fit",
        "--studies", "20", "--similarity-studies", "2", "--out", str(tmp_path / "obs"),
        timeout=900,
    )  # fmt: skip
    assert fit.returncode == 0, fit.stderr[-3000:]
    assert (tmp_path / "obs" / "report.md").is_file()


@pytest.mark.parametrize(
    ("source", "name", "file"),
    [
        ("from glarelab import glare\nglare.render_glare", "render_glare", "glare/rendering/render.py"),
        ("import glarelab.analysis.stats\nglarelab.analysis.stats.rm_anova", "rm_anova", "analysis/stats.py"),
        ("import glarelab.experiments.session\nglarelab.experiments.session", "session", "experiments/session.py"),
    ],
)  # fmt: skip
def test_an_editor_goes_to_each_definition(source, name, file):
    jedi = pytest.importorskip("jedi")  # a test dependency: pyproject's [test] extra
    script = jedi.Script(source, path=ROOT / "example.py", project=jedi.Project(ROOT))
    line = source.count("\n") + 1
    column = len(source.splitlines()[-1])
    (found,) = script.goto(line, column, follow_imports=True)
    assert found.module_path == ROOT / "src" / "glarelab" / file, found.module_path
    assert found.name == name


def test_mypy_finds_every_module():
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "mypy",
            "-p",
            "glarelab",
            "--ignore-missing-imports",
            "--no-incremental",
            "--cache-dir",
            os.devnull,
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=900,
    )
    # type errors may remain (the summary counts them); no module may be out of its reach
    assert (
        'Cannot find implementation or library stub for module named "glarelab' not in done.stdout
    )
    assert "can't find package" not in done.stdout + done.stderr
    summary = done.stdout.strip().splitlines()[-1]
    assert summary.startswith(("Success", "Found")), done.stdout[-2000:] + done.stderr[-2000:]
    checked = int(summary.rsplit("(checked ", 1)[1].split()[0])
    assert checked == len(list((ROOT / "src" / "glarelab").rglob("*.py")))


def test_ruff_sorts_glarelab_as_first_party():
    first_party = "import numpy\n\nimport glarelab\n"
    third_party = "import glarelab\nimport numpy\n"
    for source, sorted_ in ((first_party, True), (third_party, False)):
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "ruff",
                "check",
                "--select",
                "I",
                "--stdin-filename",
                "src/glarelab/example.py",
                "-",
            ],
            cwd=ROOT,
            input=source,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert (done.returncode == 0) is sorted_, (source, done.stdout)
