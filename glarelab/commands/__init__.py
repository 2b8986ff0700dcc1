"""The ``glarelab`` subcommands, one module per group; each module's ``add`` registers them."""

from . import analyse, calibrate, display, power, protocol, render, run, stimuli, tools

__all__ = ["MODULES"]

MODULES = (render, stimuli, protocol, calibrate, run, display, analyse, power, tools)
