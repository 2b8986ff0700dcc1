"""The ``glarelab`` subcommands, one module per group; each module's ``add`` registers them.

:data:`COMMANDS` names every command, its module and its one-line help, so that the parser
imports only the module of the command that runs (a command module imports what its commands
need: glare, stimuli, colour-science, PsychoPy, Dask). ``tests/test_cli_startup.py`` checks
that the table says what the modules register.
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["COMMANDS", "MODULES", "MODULE_NAMES", "load"]

MODULE_NAMES = (
    "render", "stimuli", "protocol", "calibrate", "run", "display", "analyse", "power", "tools",
    "cache",
)  # fmt: skip
COMMANDS = {  # command → (its module, its help), in the order of ``glarelab --help``
    "render": ("render", "add glare to linear float EXR images (one kernel for many files)"),
    "psf": ("render", "render a glare model's kernel as a PNG"),
    "gallery": ("render", "render the wave-optics PSF gallery"),
    "looks": ("render", "render a glare stimulus with each model"),
    "stimuli": ("stimuli", "build or verify a study's stimulus set"),
    "protocol": ("protocol", "check a protocol or list its keys"),
    "calibrate": ("calibrate", "display calibration"),
    "run": ("run", "run a study session (PsychoPy) or simulated sessions"),
    "check-display": (
        "display",
        "measure the display: resolution, refresh, frame jitter, bits, a flash's cost, and read "
        "every image of a stimulus set back from the screen",
    ),
    "analyse": ("analyse", "analyse session CSVs: tables, figures, report"),
    "import-psychopy": (
        "analyse",
        "make session files of data a PsychoPy experiment collected (ExperimentHandler CSVs)",
    ),
    "power": ("power", "power and sample size of a study's effects from simulated studies (Dask)"),
    "sweep": (
        "power",
        "the stimulus sets of a grid of protocol parameters (Dask), optionally simulated",
    ),
    "bench": ("tools", "time each speed knob against its error in display codes"),
    "docs": ("tools", "regenerate docs/protocols.md and docs/data.md"),
    "examples": ("tools", "write out the example scenes and display readings glarelab ships"),
    "demo": (
        "tools",
        "the whole study on simulated observers: stimuli, sessions, analysis, report",
    ),
    "cache": ("cache", "show or clear the cache of digitised kernels"),
}


def load(name: str) -> ModuleType:
    """The command module ``name`` of :data:`MODULE_NAMES`, imported.

    Parameters
    ----------
    name
        A name of :data:`MODULE_NAMES` (``'render'``, ``'run'``, ...).

    Returns
    -------
    types.ModuleType
        The module ``glarelab.commands.NAME``.
    """
    return importlib.import_module(f".{name}", __name__)


def __getattr__(name: str):
    if name == "MODULES":  # every command module, imported (what the full parser is made of)
        return tuple(load(module) for module in MODULE_NAMES)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
