"""Start-up: ``from glarelab import glare`` and ``glarelab --version`` import no plotting, GUI or cluster
library, and the command line imports only the module of the command that runs. (How long
start-up takes is measured by ``glarelab bench``, not here.)"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from glarelab.cli import _parser
from glarelab.commands import COMMANDS, MODULE_NAMES, load

ROOT = Path(__file__).resolve().parents[1]
# scipy.signal imports scipy.stats: 0.3 s
HEAVY = ("matplotlib", "colour", "colour.plotting", "psychopy", "dask", "distributed",
         "statsmodels", "pandas", "scipy.stats", "scipy.interpolate", "scipy.signal")  # fmt: skip


def _imported_after(code: str) -> set[str]:
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    done = subprocess.run(
        [sys.executable, "-c", probe],
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT)])},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    return set(json.loads(done.stdout.strip().splitlines()[-1]))


def test_import_glare_pulls_no_plotting_gui_or_cluster_library():
    loaded = _imported_after("from glarelab import glare")
    assert sorted(loaded & set(HEAVY)) == []


def test_a_vos_render_needs_none_of_them_either():
    code = (
        "import numpy as np\nfrom glarelab import glare\n"
        "image = np.full((32, 32), 50.0); image[16, 16] = 1e6\n"
        "glare.add_glare(image, glare.VosGlare(), pixel_deg=0.05, cache=False)\n"
        "glare.add_glare(image, glare.GaussianGlare(), pixel_deg=0.05, cache=False)\n"
        # a city whose far tail is previewed and taken (coarse convolutions)
        "rng = np.random.default_rng(0)\n"
        "city = np.full((1024, 1024), 0.5)\n"
        "city[rng.integers(0, 1024, 100), rng.integers(0, 1024, 100)] = 2e4\n"
        "renderer = glare.GlareRenderer(glare.VosGlare(), pixel_deg=0.02, shape=(1024, 1024),"
        " cache=False, paths=('multires',))\n"
        "assert renderer.render(city).plan.path == 'multires'"
    )
    assert sorted(_imported_after(code) & set(HEAVY)) == []


def test_what_glare_offers_lazily_is_there():
    from glarelab import glare

    assert glare.WaveOpticsGlare.__name__ == "WaveOpticsGlare"
    assert glare.HybridGlare.__name__ == "HybridGlare"
    assert callable(glare.render_night) and callable(glare.acuity.acuity_blur)
    assert glare.GLARE_MODELS["wave"] is glare.WaveOpticsGlare
    assert set(glare.__all__) <= set(dir(glare))
    with pytest.raises(AttributeError, match="no attribute"):
        glare.not_a_name  # noqa: B018


def test_the_halo_spectrum_defaults_skipped_unread_are_valid_names():
    import colour

    from glarelab.glare.models.spectral import _DEFAULT_NAMES, HaloSpectrum

    space, illuminant = _DEFAULT_NAMES
    assert space in colour.RGB_COLOURSPACES and illuminant in colour.SDS_ILLUMINANTS
    default = HaloSpectrum()
    assert (default.colourspace, default.illuminant) == _DEFAULT_NAMES
    with pytest.raises(ValueError, match="colourspace"):
        HaloSpectrum(colourspace="not a colourspace")


def test_version_imports_no_command_module():
    loaded = _imported_after(
        "import sys\nfrom glarelab.cli import main\n"
        "try:\n    main(['--version'])\nexcept SystemExit:\n    pass"
    )
    assert sorted(loaded & set(HEAVY)) == []
    assert "glare" not in loaded and "stimuli" not in loaded
    assert not any(m.startswith("glarelab.commands.") and m != "glarelab.commands.common"
                   for m in loaded)  # fmt: skip


def test_a_command_imports_its_own_module_only():
    loaded = _imported_after("from glarelab.cli import main\nassert main(['cache', 'info']) == 0")
    assert "glarelab.commands.cache" in loaded
    assert "glarelab.commands.render" not in loaded and "glarelab.commands.power" not in loaded


def test_the_command_table_says_what_the_modules_register():
    registered = {}
    for name in MODULE_NAMES:
        parser = argparse.ArgumentParser()
        commands = parser.add_subparsers()
        load(name).add(commands)
        for action in commands._choices_actions:
            registered[action.dest] = (name, action.help)
    assert registered == COMMANDS
    assert list(registered) == list(COMMANDS)  # the order of glarelab --help


def test_help_lists_every_command_without_importing_them(capsys):
    parser = _parser(["--help"])
    text = parser.format_help()
    for command in COMMANDS:
        assert command in text
    assert "--no-cache" in text


def test_cache_info_clear_and_no_cache(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "GLARELAB_CACHE": str(tmp_path)}

    def glarelab(*args):
        return subprocess.run(
            [sys.executable, "-m", "glarelab", *args],
            env=env,
            capture_output=True,
            text=True,
            timeout=180,
        )

    out = tmp_path / "psf.png"
    assert glarelab("--no-cache", "psf", "--out", str(out), "--size", "31").returncode == 0
    assert not (tmp_path / "kernels").exists()  # --no-cache: nothing kept
    done = glarelab("psf", "--out", str(out), "--size", "31", "--model", "gaussian")
    assert done.returncode == 0, done.stderr
    info = glarelab("cache", "info")
    assert info.returncode == 0
    assert f"directory: {tmp_path / 'kernels'}" in info.stdout
    assert "entries: 1" in info.stdout
    cleared = glarelab("cache", "clear")
    assert cleared.returncode == 0 and "removed 1 kernel " in cleared.stderr
    assert "entries: 0" in glarelab("cache", "info").stdout
