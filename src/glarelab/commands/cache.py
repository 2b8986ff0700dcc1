"""``glarelab cache info|clear``: the cache of digitised kernels
(:mod:`glarelab.glare.models.cache`)."""

from __future__ import annotations

import argparse

from .common import log as _log


def _info(args: argparse.Namespace) -> int:
    from glarelab.glare.models.cache import KernelCache

    info = KernelCache().info()
    print(f"directory: {info['directory']}")
    print(f"entries: {info['entries']}")
    print(f"size: {info['bytes'] / 2**20:.1f} MiB of at most {info['max_bytes'] / 2**20:.0f} MiB")
    return 0


def _clear(args: argparse.Namespace) -> int:
    from glarelab.glare.models.cache import KernelCache

    cache = KernelCache()
    removed = cache.clear()
    _log(f"removed {removed} kernel{'s' if removed != 1 else ''} from {cache.directory}")
    return 0


def add(commands) -> None:
    """Add the commands to the ``glarelab`` parser.

    Parameters
    ----------
    commands
        The ``glarelab`` parser's subcommands (what ``add_subparsers()`` returned); this
        module's commands are added to them.
    """
    cache = commands.add_parser(
        "cache",
        help="show or clear the cache of digitised kernels",
        description="Digitised kernels are kept in the user's cache folder ($GLARELAB_CACHE, "
        "else platformdirs' user cache, which honours XDG_CACHE_HOME), bounded in size "
        "($GLARELAB_CACHE_MAX_MB, at least 1, default 2048) with the least recently used "
        "removed first. "
        "glarelab --no-cache (or GLARELAB_NO_CACHE=1) digitises without it.",
    )
    actions = cache.add_subparsers(dest="action", required=True, metavar="ACTION")
    info = actions.add_parser("info", help="where the cache is, its entries and size")
    info.set_defaults(run=_info)
    clear = actions.add_parser("clear", help="remove every cached kernel")
    clear.set_defaults(run=_clear)
