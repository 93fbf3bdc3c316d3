"""Mitsuba 3 XML scene loading: ``load_scene(path_or_name, **params) -> Scene``."""
from __future__ import annotations

import difflib
import os

from .build import build_scene
from .errors import SceneError
from .types import (AreaEmitter, Camera, ConstantEmitter, IntegratorSpec,
                    PointEmitter, Scene)
from .xml import parse_file

__all__ = ["load_scene", "SceneError", "Scene", "Camera", "AreaEmitter",
           "PointEmitter", "ConstantEmitter", "IntegratorSpec", "builtin_scene_path"]

BUILTIN_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scenes")


def builtin_scene_path(name: str) -> str:
    """Path of the built-in scene ``name`` (``pathtracer/scenes/<name>.xml``)."""
    return os.path.join(BUILTIN_DIR, name + ".xml")


def load_scene(path: str | os.PathLike, **params) -> Scene:
    """Load a Mitsuba 3 XML scene.

    Parameters
    ----------
    path : str or path-like
        An XML file, or the name of a built-in scene (no ``/`` and no
        ``.xml``), e.g. ``"cornell-box"``, looked up in ``pathtracer/scenes``.
    **params
        Values (str, int, float) for ``$name`` placeholders in the file; they
        override the file's ``<default>`` values.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        If the file is malformed or uses something this tracer does not
        render like Mitsuba; the message names the file, line and element.
    """
    text = os.fspath(path)
    if "/" not in text and os.sep not in text and not text.endswith(".xml"):
        file = builtin_scene_path(text)
        if not os.path.isfile(file):
            names = sorted(f[:-4] for f in os.listdir(BUILTIN_DIR) if f.endswith(".xml")) \
                if os.path.isdir(BUILTIN_DIR) else []
            close = difflib.get_close_matches(text, names, n=1)
            hint = f"did you mean \"{close[0]}\"? " if close else ""
            raise SceneError(f"no built-in scene \"{text}\" ({hint}built-in: {', '.join(names) or 'none'}; "
                             "give a path to load a file)")
    else:
        file = text
        if os.path.isdir(file):
            raise SceneError(f"{file} is a directory, not a scene file")
        if not os.path.isfile(file):
            raise SceneError(f"scene file not found: {file}")
    root = parse_file(file, params)
    return build_scene(root, text, os.path.dirname(os.path.abspath(file)))
