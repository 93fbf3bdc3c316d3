"""Where references are looked up and written.

Two folders, searched in this order:

1. the **committed** references of the built-in scenes, ``mitsuba_refs/references`` inside the
   package (:func:`committed_dir`): read only, never written by a lookup;
2. the **user cache** (:func:`cache_dir`): ``$MITSUBA_REFS_CACHE`` if set, else the platform's
   cache folder (``$XDG_CACHE_HOME/mitsuba-refs``, ``~/.cache/mitsuba-refs``,
   ``~/Library/Caches/mitsuba-refs`` on macOS, ``%LOCALAPPDATA%\\mitsuba-refs`` on Windows).
   Every reference rendered on demand is written here, never into the installed package.

A cluster shares one user cache: point ``MITSUBA_REFS_CACHE`` on the client and on every
worker at one folder of a shared file system (docs/cluster.md). References are named by what
they are (:func:`mitsuba_refs.reference.cache.reference_key`), not where the scene lies, so
any machine finds them.
"""

import os
import sys
from pathlib import Path

from . import config

#: The folder's name inside the platform's cache directory.
APP_NAME = "mitsuba-refs"


def committed_dir() -> Path:
    """The package's folder of committed references (read only)."""
    return Path(__file__).resolve().parents[1] / "references"


def platform_cache_root() -> Path:
    """The platform's per-user cache directory."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    xdg = os.environ.get("XDG_CACHE_HOME")
    return Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache"


def cache_dir() -> Path:
    """The user cache: ``$MITSUBA_REFS_CACHE`` if set, else the platform's cache folder."""
    env = os.environ.get(config.ENV_CACHE)
    if env:
        return Path(env)
    return platform_cache_root() / APP_NAME


def lookup_dirs(directory=None) -> list:
    """The folders a lookup reads, in order: ``directory`` alone when given, else the
    committed references, then the user cache."""
    if directory is not None:
        return [Path(directory)]
    return [committed_dir(), cache_dir()]
